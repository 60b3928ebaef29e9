// Page side of the decode worker: sends frames and configuration, keeps only the newest decoded
// frame for the next render and hands older buffers straight back to the worker.

export class DecoderClient {
  // callbacks: onConfigured({ pts, texW, texH, nrmOffset }), onError(message, needKeyframe),
  // onDecoded(msg) for statistics (the message of every decoded frame).
  constructor(callbacks) {
    this.cb = callbacks;
    this.worker = new Worker(new URL('./decode_worker.js', import.meta.url), { type: 'module' });
    this.worker.onmessage = (ev) => this._onMessage(ev.data);
    this.worker.onerror = (ev) => this.cb.onError(`decode worker failed: ${ev.message || 'load error'}`, false);
    this.gen = 0;
    this.pending = null; // newest decoded frame not yet uploaded
    this.inFlight = 0;
    this.recycleMsg = { type: 'recycle', gen: 0, buf: null }; // reused: no allocation per frame
    this.transfer = [null];
  }

  // (Re)configures for nstrands x nverts guides smoothed with segs points per span; rest roots
  // (head frame, xyz per strand) let the worker recover the head pose.
  configure(nstrands, nverts, segs, maxTexW, restRoots) {
    this.gen++;
    this.pending = null;
    this.worker.postMessage({ type: 'config', gen: this.gen, nstrands, nverts, segs, maxTexW, restRoots: Float32Array.from(restRoots) });
  }

  // Forwards one binary frame (the ArrayBuffer is transferred, not copied).
  push(data, arrival) {
    this.inFlight++;
    this.worker.postMessage({ type: 'frame', data, arrival }, [data]);
  }

  // Forgets the decoder's keyframe (after a groom change or reconnect).
  resetDecoder() {
    this.worker.postMessage({ type: 'reset' });
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
    if (m.type === 'frame') {
      this.inFlight = Math.max(0, this.inFlight - 1);
      if (m.gen !== this.gen) return;
      if (this.pending) this.recycle(this.pending);
      this.pending = m;
      this.cb.onDecoded(m);
    } else if (m.type === 'configured') {
      if (m.gen === this.gen) this.cb.onConfigured(m);
    } else if (m.type === 'error') {
      this.inFlight = Math.max(0, this.inFlight - 1);
      this.cb.onError(m.message, m.needKeyframe);
    } else if (m.type === 'skipped' || m.type === 'dropped') {
      this.inFlight = Math.max(0, this.inFlight - 1);
    }
  }
}
