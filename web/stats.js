// Stream and render statistics: windowed rates and a latency estimate, in fixed-size rings.

// Counts events and bytes over the last windowMs; add() and read methods allocate nothing.
export class RateMeter {
  constructor(windowMs = 1000, capacity = 1024) {
    this.windowMs = windowMs;
    this.t = new Float64Array(capacity);
    this.b = new Float64Array(capacity);
    this.head = 0; // next write slot
    this.n = 0;
    this.since = NaN; // time of the first event since reset
  }

  add(nowMs, bytes = 0) {
    if (!(this.since <= nowMs)) this.since = nowMs;
    this.t[this.head] = nowMs;
    this.b[this.head] = bytes;
    this.head = (this.head + 1) % this.t.length;
    if (this.n < this.t.length) this.n++;
  }

  _scan(nowMs, wantBytes) {
    if (this.n === 0) return 0;
    const cap = this.t.length;
    let count = 0, bytes = 0, k = 1;
    for (; k <= this.n; k++) {
      const i = (this.head - k + cap) % cap;
      if (nowMs - this.t[i] > this.windowMs) break;
      count++;
      bytes += this.b[i];
    }
    // the span the counted events cover: the window, or less while the meter is younger than
    // the window or when the ring filled up inside it
    let span = Math.min(this.windowMs, nowMs - this.since);
    if (k > this.n && this.n === cap) span = Math.min(span, nowMs - this.t[this.head]);
    span = Math.max(span, 1);
    return ((wantBytes ? bytes : count) * 1000) / span;
  }

  // Events per second over the window.
  perSecond(nowMs) { return this._scan(nowMs, false); }

  // Bytes per second over the window.
  bytesPerSecond(nowMs) { return this._scan(nowMs, true); }

  reset() { this.n = 0; this.head = 0; this.since = NaN; }
}

// Exponential moving average.
export class Ema {
  constructor(alpha = 0.1) { this.alpha = alpha; this.value = NaN; }
  add(x) { this.value = Number.isFinite(this.value) ? this.value + this.alpha * (x - this.value) : x; return this.value; }
  reset() { this.value = NaN; }
}

// Latency from the server's simulation clock. Each frame's arrival time minus its sim time
// (scaled by the rate r at which sim time advances per wall second, measured over the window,
// so a server running slower than real time does not look like growing latency) is a clock
// offset plus the transport delay. The smallest offset in the window stands for the fastest
// delivery; latency = this frame's offset - that minimum (ms). A sim time that goes backwards
// (reset, new groom) restarts the estimate.
export class LatencyEstimator {
  constructor(windowMs = 5000, capacity = 1024) {
    this.windowMs = windowMs;
    this.t = new Float64Array(capacity);
    this.sim = new Float64Array(capacity);
    this.head = 0;
    this.n = 0;
    this.lastSim = -Infinity;
    this.value = NaN;
    this.rate = 1;
    this.rated = false;
  }

  reset() { this.n = 0; this.head = 0; this.lastSim = -Infinity; this.value = NaN; this.rate = 1; this.rated = false; }

  // Records a frame of simulation time simSeconds arriving at nowMs; returns the latency.
  add(nowMs, simSeconds) {
    if (!Number.isFinite(simSeconds)) return this.value;
    if (simSeconds < this.lastSim) this.reset();
    this.lastSim = simSeconds;
    this.t[this.head] = nowMs;
    this.sim[this.head] = simSeconds * 1000;
    this.head = (this.head + 1) % this.t.length;
    if (this.n < this.t.length) this.n++;
    const cap = this.t.length;
    let oldest = (this.head - 1 + cap) % cap, count = 0;
    for (let k = 1; k <= this.n; k++) {
      const i = (this.head - k + cap) % cap;
      if (nowMs - this.t[i] > this.windowMs) break;
      oldest = i;
      count++;
    }
    const wallSpan = nowMs - this.t[oldest], simSpan = simSeconds * 1000 - this.sim[oldest];
    // the sim clock's speed relative to the wall clock, once the window holds enough of both;
    // smoothed so that one late frame does not bend it
    if (count >= 8 && wallSpan > 500 && simSpan > 0) {
      const inst = simSpan / wallSpan;
      this.rate = this.rated ? this.rate + 0.05 * (inst - this.rate) : inst;
      this.rated = true;
    }
    const r = this.rate;
    const off = nowMs - (simSeconds * 1000) / r;
    let min = off;
    for (let k = 1; k <= count; k++) {
      const i = (this.head - k + cap) % cap;
      const o = this.t[i] - this.sim[i] / r;
      if (o < min) min = o;
    }
    this.value = off - min;
    return this.value;
  }
}
