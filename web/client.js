// A strandcastd client for programs and tests (ES module; browser, Worker or Node 20): one
// WebSocket with the protocol's subprotocol, the hello, requests whose promises settle with their
// replies (matched by id, proto/PROTOCOL.md), announcements as events, strand frames decoded to
// Float32Array by the daemon's decoder (codec.js) and the groom's data binary (groom_data.js).
// The viewer shares its request, hello and frame header handling (net.js, stream_client.js,
// stream_worker.js). No reconnects: a lost connection ends the client (the viewer's net.js
// reconnects).
import { StrandDecoder } from './codec.js';
import { blobUrl, httpBase, parseGroomData } from './groom_data.js';

export const SUBPROTOCOL = 'strandcast.v3';
export const PROTOCOL_VERSION = 3;
// Close codes after the error of a connection whose path names no valid room (bad_room) or a room
// the server does not serve (unknown_room), proto/PROTOCOL.md "Rooms".
export const CLOSE_BAD_ROOM = 4400;
export const CLOSE_UNKNOWN_ROOM = 4404;
// Decoded frames a frames() iterator holds for a reader that lags; older ones are dropped.
const FRAME_QUEUE = 64;
const ANNOUNCEMENTS = ['params', 'state', 'groom', 'stats', 'error', 'frame', 'close'];

// An error reply of the server as an Error: code (PROTOCOL.md "Errors": 'out_of_range',
// 'bad_field', ...), field (the path of the offending field, '' for the whole message), id and
// the reply itself.
export class ProtocolError extends Error {
  constructor(reply) {
    const field = typeof reply.field === 'string' ? reply.field : '';
    super(`${reply.code}${field ? ` (${field})` : ''}: ${reply.message}`);
    this.name = 'ProtocolError';
    this.code = reply.code;
    this.field = field;
    this.id = reply.id;
    this.reply = reply;
  }
}

// Why a hello cannot be used (it names another protocol version), or null when it can; who: how
// the message names this side ('this client', 'this page').
export function helloMismatch(hello, who = 'this client') {
  if (hello.protocol === PROTOCOL_VERSION) return null;
  return `the server speaks protocol ${JSON.stringify(hello.protocol)} (${hello.server || 'unknown server'} ${hello.version || ''}), ${who} speaks protocol ${PROTOCOL_VERSION}`;
}

// The header of a decoded frame (a codec.js header record) as a plain object: seq, refSeq,
// simTime (s), simStep, keyframe, head { position [x,y,z], orientation [x,y,z,w] }, counts
// (nstrandsTotal, nstrandsSent, nverts, stride), maxError (m) and bytes (the frame's length).
export function frameHeader(info) {
  return {
    seq: info.seq, refSeq: info.refSeq, simTime: info.simTime, simStep: info.simStep, keyframe: info.keyframe,
    head: { position: Array.from(info.headPosition), orientation: Array.from(info.headOrientation) },
    nstrandsTotal: info.nstrandsTotal, nstrandsSent: info.nstrandsSent, nverts: info.nverts, stride: info.stride,
    maxError: info.maxError, bytes: info.frameLen, codec: info.codec,
  };
}

// Ids and pending replies of one connection's requests. track(msg) gives msg an id (a fresh one
// when it has none; motion messages without one get none, having no reply) and returns a promise
// of its reply: resolved with the ok/params/state/subscribed reply, rejected with a
// ProtocolError for an error reply. settle(msg) takes a received message: true when it was the
// reply to a tracked request. rejectAll(error) rejects every pending request. Owned by one
// thread (the one that reads the socket). prefix: ids are numbers 1, 2, ... without one, else
// strings prefix + number (two senders on one connection, each with its own prefix, never clash).
export class Requests {
  constructor(prefix = '') {
    this.prefix = prefix;
    this.nextId = 1;
    this.pending = new Map();
  }

  get size() { return this.pending.size; }

  // Assigns msg's id (see above) and returns it, or undefined for a motion without one.
  assign(msg) {
    if (msg.id === undefined && msg.type !== 'motion') msg.id = this.prefix ? `${this.prefix}${this.nextId++}` : this.nextId++;
    return msg.id;
  }

  track(msg) {
    const id = this.assign(msg);
    if (id === undefined) return Promise.resolve(null);
    if (this.pending.has(id)) return Promise.reject(new Error(`request id ${JSON.stringify(id)} is already waiting for its reply`));
    return new Promise((resolve, reject) => this.pending.set(id, { resolve, reject }));
  }

  settle(msg) {
    if (msg.id === undefined || msg.type === 'hello') return false;
    const p = this.pending.get(msg.id);
    if (!p) return false;
    this.pending.delete(msg.id);
    if (msg.type === 'error') p.reject(new ProtocolError(msg));
    else p.resolve(msg);
    return true;
  }

  rejectAll(error) {
    const all = [...this.pending.values()];
    this.pending.clear();
    for (const p of all) p.reject(error);
  }
}

// A connected client (made by connect()). hello: the server's hello. request(msg) sends a control
// message (PROTOCOL.md "Client messages") and returns a promise of its reply (see Requests);
// send(msg) sends without waiting. on(type, fn) / off(type, fn): announcements 'params', 'state',
// 'groom', 'stats', 'error' (errors without an id), 'frame' (each decoded frame) and 'close'
// ({ code, reason }). frames() iterates decoded frames as they arrive. groomData() fetches the
// current groom's data binary. close() ends the connection; pending requests are rejected.
// Single-threaded: use from the thread that made it.
export class Client {
  constructor(ws, url, options) {
    this.ws = ws;
    this.url = url;
    this.hello = null;
    this.groom = null;           // the current groom description (hello's, then each groom message's)
    this.closed = null;          // { code, reason } once the connection ended
    this.requests = new Requests();
    this.decoder = options.decode === false ? null : (options.decoder || new StrandDecoder());
    this.fetch = options.fetch || ((...a) => fetch(...a));
    this.listeners = new Map(ANNOUNCEMENTS.map((t) => [t, new Set()]));
    this.readers = new Set();    // frames() iterators: { queue, wake }
    this.framesDropped = 0;      // frames a lagging frames() reader missed
    this.decodeErrors = 0;       // frames that could not be decoded (other than a missing keyframe)
    this.lastKeyRequest = -Infinity;
  }

  on(type, fn) {
    const set = this.listeners.get(type);
    if (!set) throw new Error(`unknown event "${type}" (one of ${ANNOUNCEMENTS.join(', ')})`);
    set.add(fn);
    return this;
  }

  off(type, fn) {
    const set = this.listeners.get(type);
    if (set) set.delete(fn);
    return this;
  }

  send(msg) {
    if (this.closed) throw new Error(`strandcast client: the connection is closed (${this.closed.reason})`);
    this.ws.send(JSON.stringify(msg));
  }

  request(msg) {
    if (this.closed) return Promise.reject(new Error(`strandcast client: the connection is closed (${this.closed.reason})`));
    const reply = this.requests.track(msg);
    this.ws.send(JSON.stringify(msg));
    return reply;
  }

  // Fetches and parses the current groom's data binary (GET hello.groom.url, relative to the
  // server's HTTP address): { strands, verts, restLengths, roots } (groom_data.js).
  async groomData() {
    const g = this.groom;
    if (!g || typeof g.url !== 'string') throw new Error('strandcast client: the groom description names no data url');
    const url = blobUrl(g.url, httpBase(this.url));
    const r = await this.fetch(url, { cache: 'no-cache' });
    if (!r.ok) throw new Error(`strandcast client: GET ${url}: HTTP ${r.status}`);
    return parseGroomData(await r.arrayBuffer());
  }

  // Decoded frames, oldest first, from the next one received until the connection closes: each
  // { header (frameHeader()), positions: Float32Array of 3 * nstrandsSent * nverts, strand-major
  // xyz, a copy the decoder does not reuse, shared with the other readers and 'frame' listeners }.
  // A reader more than FRAME_QUEUE frames behind loses the oldest.
  frames() {
    if (!this.decoder) throw new Error('strandcast client: connected with decode: false, frames are not decoded');
    const reader = { queue: [], wake: null };
    this.readers.add(reader);
    const done = () => { this.readers.delete(reader); return { value: undefined, done: true }; };
    return {
      next: () => {
        if (reader.queue.length) return Promise.resolve({ value: reader.queue.shift(), done: false });
        if (this.closed) return Promise.resolve(done());
        return new Promise((resolve) => {
          reader.wake = () => {
            reader.wake = null;
            resolve(reader.queue.length ? { value: reader.queue.shift(), done: false } : done());
          };
        });
      },
      return: () => Promise.resolve(done()),
      [Symbol.asyncIterator]() { return this; },
    };
  }

  close(reason = 'closed by the client') {
    if (!this.closed) {
      try { this.ws.close(1000, reason); } catch { /* already closing */ }
      this._ended(1000, reason);
    }
  }

  _emit(type, value) {
    for (const fn of this.listeners.get(type)) fn(value);
  }

  _text(data) {
    let msg;
    try { msg = JSON.parse(data); } catch { return; }
    if (!msg || typeof msg !== 'object' || typeof msg.type !== 'string') return;
    if (this.requests.settle(msg)) return;
    if (msg.type === 'groom') {
      this.groom = msg.groom;
      if (this.decoder) this.decoder.reset();
    }
    if (this.listeners.has(msg.type)) this._emit(msg.type, msg);
  }

  _binary(data) {
    if (!this.decoder) return;
    let info;
    try {
      info = this.decoder.decode(new Uint8Array(data));
    } catch (e) {
      if (/needs keyframe/.test(e.message)) this._requestKeyframe();
      else this.decodeErrors++;
      return;
    }
    const frame = { header: frameHeader(info), positions: Float32Array.from(info.positions) };
    this._emit('frame', frame);
    for (const r of this.readers) {
      if (r.queue.length >= FRAME_QUEUE) { r.queue.shift(); this.framesDropped++; }
      r.queue.push(frame);
      if (r.wake) r.wake();
    }
  }

  _requestKeyframe() {
    const now = Date.now();
    if (now - this.lastKeyRequest < 1000 || this.closed) return;
    this.lastKeyRequest = now;
    this.request({ type: 'keyframe' }).catch(() => {});
  }

  _ended(code, reason) {
    if (this.closed) return;
    this.closed = { code, reason };
    this.requests.rejectAll(new Error(`strandcast client: the connection closed before the reply came (${reason || `code ${code}`})`));
    for (const r of this.readers) if (r.wake) r.wake();
    this._emit('close', this.closed);
  }
}

// Connects to strandcastd at url (ws://HOST:PORT/) and resolves with a Client once the hello
// arrived (and, with a token and a hello asking for one, once auth was accepted). Rejects when the
// server refuses the subprotocol, speaks another protocol version, refuses the token or closes
// first, or after timeoutMs. options (all optional): WebSocket (the constructor; default
// globalThis.WebSocket; Node 20 has none: pass the npm 'ws' package's), token, decode (false:
// frames are not decoded), decoder (a codec.js StrandDecoder), fetch (for groomData()),
// timeoutMs (default 10000).
export function connect(url, options = {}) {
  const WS = options.WebSocket || globalThis.WebSocket;
  if (typeof WS !== 'function') return Promise.reject(new Error('strandcast client: no WebSocket (in Node 20 pass { WebSocket } from the "ws" package)'));
  return new Promise((resolve, reject) => {
    let ws;
    try { ws = new WS(url, SUBPROTOCOL); } catch (e) { reject(new Error(`strandcast client: cannot open ${url}: ${e.message}`)); return; }
    ws.binaryType = 'arraybuffer';
    const client = new Client(ws, url, options);
    let settled = false;
    const fail = (why, error) => {
      if (settled) return;
      settled = true;
      clearTimeout(timer);
      try { ws.close(1000, 'connect failed'); } catch { /* already closing */ }
      client._ended(1006, why);
      reject(error || new Error(`strandcast client: ${why}`));
    };
    const timer = setTimeout(() => fail(`no hello from ${url} within ${options.timeoutMs || 10000} ms`), options.timeoutMs || 10000);
    ws.addEventListener('open', () => {
      if (ws.protocol !== SUBPROTOCOL) fail(`the server did not accept the subprotocol ${SUBPROTOCOL} (it answered "${ws.protocol}")`);
    });
    ws.addEventListener('error', () => { /* close follows with the details */ });
    ws.addEventListener('close', (ev) => {
      const why = ev.reason ? `${ev.reason} (code ${ev.code})` : `code ${ev.code}`;
      if (!settled) fail(`the connection to ${url} closed before the hello: ${why}`);
      else client._ended(ev.code, why);
    });
    ws.addEventListener('message', (ev) => {
      if (typeof ev.data !== 'string') { if (settled) client._binary(ev.data); return; }
      if (settled) { client._text(ev.data); return; }
      let hello;
      try { hello = JSON.parse(ev.data); } catch { hello = null; }
      // a refusal before any hello (a room this server does not serve, bad_room / unknown_room)
      if (hello && hello.type === 'error') { fail(hello.message, new ProtocolError(hello)); return; }
      if (!hello || hello.type !== 'hello') { fail('the first message was not a hello'); return; }
      const mismatch = helloMismatch(hello, 'this client');
      if (mismatch) { fail(mismatch); return; }
      client.hello = hello;
      client.groom = hello.groom;
      settled = true;
      clearTimeout(timer);
      if (hello.access !== 'token' || !options.token) { resolve(client); return; }
      client.request({ type: 'auth', token: options.token }).then(() => resolve(client), (e) => {
        client.close('token refused');
        reject(e);
      });
    });
  });
}
