// The viewer's WebSocket connection to strandcastd: subprotocol check, JSON control messages,
// binary strand frames, a silence watchdog, and reconnects with backoff after a lost connection.
// The protocol's constants, hello check and request ids are client.js's (the client module).
import { Backoff } from './backoff.js';
import { CLOSE_BAD_ROOM, CLOSE_UNKNOWN_ROOM, PROTOCOL_VERSION, Requests, SUBPROTOCOL, helloMismatch } from './client.js';

export { PROTOCOL_VERSION, SUBPROTOCOL };
// The server sends stats about once a second; a connection silent for this long is taken as
// half-open (sleep, NAT drop) and reopened. Generous, as a loaded server may step slowly.
const WATCHDOG_MS = 30000;

// The endpoint for a page served by strandcastd: same host, ws or wss like the page.
export function defaultUrl(loc) {
  const room = (loc.pathname || '').startsWith('/rooms/') ? loc.pathname : '/'; // the page of a room: its socket
  return `${loc.protocol === 'https:' ? 'wss' : 'ws'}://${loc.host}${room}`;
}

// The access token in a page URL ending in #token=TOKEN (strandcastd --token-file), or null. When
// there is one it is removed from the address bar (history.replaceState), so it is not shown,
// bookmarked or shared with the page; the page keeps it in memory only.
export function takeToken(loc, history) {
  const m = /(?:^#|&)token=([^&]*)/.exec(loc.hash || '');
  if (!m) return null;
  let token = null;
  try { token = decodeURIComponent(m[1]); } catch { token = null; }
  if (history && history.replaceState) history.replaceState(null, '', loc.pathname + loc.search);
  return token || null;
}

// Callbacks (all optional): onHello(hello), onMessage(msg) for every other JSON message,
// onBinary(ArrayBuffer), onStatus({ state: 'connecting' | 'open' | 'lost' | 'refused' |
// 'mismatch', attempt, delayMs, reason }). 'refused' (the server is up but keeps refusing the
// handshake) keeps retrying; 'mismatch' (hello names another protocol) stops. Call start() once.
// token (optional): sent as auth after every hello whose access is 'token' (reconnects included).
export class Connection {
  constructor(url, callbacks, backoffOptions, token = null) {
    this.url = url;
    this.token = token;
    this.cb = callbacks;
    this.backoff = new Backoff(backoffOptions);
    this.ws = null;
    // ids only (replies go to onMessage), 'w1', 'w2', ...: the page's own requests (numbered by
    // stream_client.js) share this connection
    this.requests = new Requests('w');
    this.stopped = false;
    this.helloSeen = false;
    this.lastMessage = 0;
    this.timer = null;
    this.watchdog = null;
    this.bytesIn = 0;
    this.refusals = 0; // handshakes refused in a row while the HTTP side answered
  }

  _status(s) { if (this.cb.onStatus) this.cb.onStatus(s); }

  start() {
    this.stopped = false;
    this._open();
    this.watchdog = setInterval(() => {
      if (this.ws && this.ws.readyState === WebSocket.OPEN && performance.now() - this.lastMessage > WATCHDOG_MS) {
        this.ws.close(4000, 'no data from the server');
        this._lost('no data from the server for ' + WATCHDOG_MS / 1000 + ' s');
      }
    }, 1000);
  }

  // Stops for good (no more reconnects).
  stop(reason) {
    this.stopped = true;
    clearTimeout(this.timer);
    clearInterval(this.watchdog);
    if (this.ws) {
      const ws = this.ws;
      this.ws = null;
      ws.onopen = ws.onmessage = ws.onclose = ws.onerror = null;
      try { ws.close(1000, reason || 'closed by the page'); } catch { /* already closing */ }
    }
  }

  get open() { return !!this.ws && this.ws.readyState === WebSocket.OPEN && this.helloSeen; }

  // Sends a control message; returns its id (assigned when missing, Requests.assign) or null when
  // not connected.
  send(msg) {
    if (!this.open) return null;
    const id = this.requests.assign(msg);
    this.ws.send(JSON.stringify(msg));
    return id === undefined ? 0 : id;
  }

  _open() {
    this._status({ state: 'connecting', attempt: this.backoff.attempt });
    let ws;
    try {
      ws = new WebSocket(this.url, SUBPROTOCOL);
    } catch (e) {
      this._lost(`cannot open ${this.url}: ${e.message}`);
      return;
    }
    ws.binaryType = 'arraybuffer';
    this.ws = ws;
    this.helloSeen = false;
    ws.onopen = () => {
      this.lastMessage = performance.now();
      if (ws.protocol !== SUBPROTOCOL) {
        this._mismatch(`the server did not accept the subprotocol ${SUBPROTOCOL} (it answered "${ws.protocol}")`);
      }
    };
    ws.onmessage = (ev) => this._message(ev.data);
    let opened = false;
    ws.addEventListener('open', () => { opened = true; this.refusals = 0; });
    ws.onclose = (ev) => {
      if (this.ws !== ws) return;
      const why = ev.reason ? `${ev.reason} (code ${ev.code})` : `code ${ev.code}`;
      if (!this.helloSeen && ev.code === 1002) this._mismatch(`the server refused the connection: ${why}`);
      else if (ev.code === CLOSE_BAD_ROOM || ev.code === CLOSE_UNKNOWN_ROOM) this._noRoom(ev.reason || why);
      else if (!opened) this._refused(why);
      else this._lost(why);
    };
    ws.onerror = () => { /* onclose follows with the details */ };
  }

  _message(data) {
    this.lastMessage = performance.now();
    if (typeof data !== 'string') {
      this.bytesIn += data.byteLength;
      if (this.helloSeen && this.cb.onBinary) this.cb.onBinary(data);
      return;
    }
    this.bytesIn += data.length;
    let msg;
    try {
      msg = JSON.parse(data);
    } catch {
      console.warn('strandcast: ignoring a text message that is not JSON');
      return;
    }
    if (!msg || typeof msg !== 'object' || typeof msg.type !== 'string') return;
    if (msg.type === 'hello') {
      const mismatch = helloMismatch(msg, 'this page');
      if (mismatch) {
        this._mismatch(mismatch);
        return;
      }
      this.helloSeen = true;
      this.backoff.reset();
      this._status({ state: 'open' });
      if (msg.access === 'token' && this.token) this.send({ type: 'auth', token: this.token });
      if (this.cb.onHello) this.cb.onHello(msg);
      return;
    }
    if (this.helloSeen && this.cb.onMessage) this.cb.onMessage(msg);
  }

  // The handshake failed. Browsers hide why; if the server still answers HTTP it is up and
  // refused the WebSocket, which strandcastd does for a subprotocol (version) it does not speak.
  _refused(why) {
    this._lost(`the WebSocket handshake failed (${why})`);
    const httpUrl = this.url.replace(/^ws/, 'http');
    fetch(httpUrl, { cache: 'no-store' }).then((r) => {
      if (this.stopped || this.helloSeen) return;
      if (r.status < 500 && ++this.refusals >= 2) {
        this._status({ state: 'refused', reason: `the server at ${httpUrl} answers HTTP but refused the ${SUBPROTOCOL} WebSocket ${this.refusals} times: most likely a protocol version mismatch (reload the page from that server)` });
      }
    }, () => { this.refusals = 0; });
  }

  // The server does not serve the room the URL names: no reconnects (they would be refused alike).
  _noRoom(reason) {
    this._status({ state: 'no_room', reason });
    this.stop('no such room');
  }

  _mismatch(reason) {
    this._status({ state: 'mismatch', reason });
    this.stop('protocol mismatch');
  }

  _lost(reason) {
    if (this.stopped) return;
    if (this.ws) {
      const ws = this.ws;
      this.ws = null;
      ws.onopen = ws.onmessage = ws.onclose = ws.onerror = null;
      try { ws.close(); } catch { /* already closed */ }
    }
    this.helloSeen = false;
    const attempt = this.backoff.attempt + 1;
    const delayMs = this.backoff.next();
    this._status({ state: 'lost', attempt, delayMs, reason });
    clearTimeout(this.timer);
    this.timer = setTimeout(() => this._open(), delayMs);
  }
}
