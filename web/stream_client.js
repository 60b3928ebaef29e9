// Page side of the stream worker: starts the connection, sends control messages (requests whose
// promises settle with their replies, as the client module's: client.js Requests), configures
// the guide buffers, keeps only the newest decoded frame for the next render and hands older
// buffers straight back to the worker.
import { Requests } from './client.js';

export class StreamClient {
  // callbacks: onHello(hello), onMessage(msg) (every message but the replies to request()),
  // onStatus(status) (see net.js Connection),
  // onConfigured({ gen, pts, texW, texH, tanOffset }), onDecoded(frame) for statistics (every
  // decoded frame; frame.arrival is on this page's performance.now() clock), onError(message).
  constructor(callbacks) {
    this.cb = callbacks;
    this.worker = new Worker(new URL('./stream_worker.js', import.meta.url), { type: 'module' });
    this.worker.onmessage = (ev) => this._onMessage(ev.data);
    this.worker.onerror = (ev) => this.cb.onError(`stream worker failed: ${ev.message || 'load error'}`);
    this.gen = 0;
    this.pending = null; // newest decoded frame not yet uploaded
    this.open = false;   // a hello arrived and the connection has not been lost since
    this.requests = new Requests();
    this.recycleMsg = { type: 'recycle', gen: 0, buf: null }; // reused: no allocation per frame
    this.transfer = [null];
  }

  // Connects to url (ws:// or wss://); backoff: reconnect delay options (backoff.js); token: the
  // server's access token (sent as auth when the hello asks for one), or null.
  start(url, backoff, token = null) {
    this.worker.postMessage({ type: 'start', url, backoff, token });
  }

  // Sends a control message; returns its id (assigned unless it is a motion message, which
  // gets no reply) or null when not connected.
  send(msg) {
    if (!this.open) return null;
    const id = this.requests.assign(msg);
    this.worker.postMessage({ type: 'send', message: msg });
    return id === undefined ? 0 : id;
  }

  // Sends a control message with a fresh id; returns a promise of its reply (client.js Requests:
  // rejected with a ProtocolError for an error reply, with an Error when the connection is lost
  // first), or null when not connected.
  request(msg) {
    if (!this.open) return null;
    const reply = this.requests.track(msg);
    this.worker.postMessage({ type: 'send', message: msg });
    return reply;
  }

  // (Re)configures for nstrands x nverts guides smoothed with segs points per span; with mode
  // 'hairmesh', for hair mesh frames of nstrands columns x nverts layers instead.
  configure(nstrands, nverts, segs, maxTexW, mode = 'strands') {
    this.gen++;
    this.pending = null;
    this.worker.postMessage({ type: 'config', gen: this.gen, nstrands, nverts, segs, maxTexW, mode });
  }

  // The newest decoded frame, once; the caller uploads it and then calls recycle(frame).
  take() {
    const f = this.pending;
    this.pending = null;
    return f;
  }

  recycle(frame) {
    this.recycleMsg.gen = frame.gen;
    this.recycleMsg.buf = frame.buf;
    this.transfer[0] = frame.buf.buffer;
    this.worker.postMessage(this.recycleMsg, this.transfer);
    this.recycleMsg.buf = null;
    this.transfer[0] = null;
  }

  _onMessage(m) {
    switch (m.type) {
      case 'frame':
        m.arrival -= performance.timeOrigin;
        if (m.gen !== this.gen) { this.recycle(m); return; }
        if (this.pending) this.recycle(this.pending);
        this.pending = m;
        this.cb.onDecoded(m);
        break;
      case 'hello': this.open = true; this.cb.onHello(m.hello); break;
      case 'message': if (!this.requests.settle(m.message)) this.cb.onMessage(m.message); break;
      case 'status':
        if (m.status.state !== 'open') {
          this.open = false;
          this.requests.rejectAll(new Error(`the connection was ${m.status.state === 'connecting' ? 'reopened' : m.status.state} before the reply came`));
        }
        this.cb.onStatus(m.status);
        break;
      case 'configured': if (m.gen === this.gen) this.cb.onConfigured(m); break;
      case 'error': this.cb.onError(m.message); break;
      default: break;
    }
  }
}
