// Reconnect delays: exponential backoff with jitter and a cap, reset after a good session.

// Delay in ms before reconnect attempt number attempt (0 = first retry):
// min(maxMs, baseMs * factor^attempt) scaled by 1 + jitter * (2 r - 1) for r in [0, 1),
// never above maxMs.
export function backoffDelay(attempt, { baseMs = 500, factor = 2, maxMs = 10000, jitter = 0.2 } = {}, r = 0.5) {
  const n = attempt > 0 ? Math.floor(attempt) : 0;
  const raw = Math.min(maxMs, baseMs * Math.pow(factor, Math.min(n, 60)));
  return Math.min(maxMs, Math.max(0, raw * (1 + jitter * (2 * r - 1))));
}

// Stateful wrapper: next() returns the delay for the next attempt and counts it; reset()
// starts over (call it once a connection has said hello).
export class Backoff {
  constructor(opts = {}, random = Math.random) {
    this.opts = opts;
    this.random = random;
    this.attempt = 0;
  }

  next() {
    return backoffDelay(this.attempt++, this.opts, this.random());
  }

  reset() {
    this.attempt = 0;
  }
}
