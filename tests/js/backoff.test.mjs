// Tests web/backoff.js: reconnect delays grow, stay capped and jittered, and reset.
import test from 'node:test';
import assert from 'node:assert/strict';
import { Backoff, backoffDelay } from '../../web/backoff.js';

test('delays double from the base up to the cap', () => {
  const o = { baseMs: 250, factor: 2, maxMs: 4000, jitter: 0 };
  assert.deepEqual([0, 1, 2, 3, 4, 5, 50, 1e9].map((a) => backoffDelay(a, o)), [250, 500, 1000, 2000, 4000, 4000, 4000, 4000]);
});

test('jitter spreads delays within +-jitter but never past the cap', () => {
  const o = { baseMs: 1000, factor: 2, maxMs: 8000, jitter: 0.25 };
  assert.equal(backoffDelay(1, o, 0), 1500);
  assert.equal(backoffDelay(1, o, 0.5), 2000);
  assert.ok(Math.abs(backoffDelay(1, o, 0.999999) - 2500) < 0.01);
  assert.equal(backoffDelay(10, o, 0.999), 8000);
  assert.ok(backoffDelay(10, o, 0) >= 6000);
});

test('bad attempt numbers are treated as the first attempt', () => {
  assert.equal(backoffDelay(-3, { jitter: 0 }), 500);
  assert.equal(backoffDelay(NaN, { jitter: 0 }), 500);
});

test('Backoff counts attempts and reset() starts over', () => {
  const b = new Backoff({ baseMs: 100, maxMs: 1000, jitter: 0 }, () => 0.5);
  assert.deepEqual([b.next(), b.next(), b.next(), b.next(), b.next()], [100, 200, 400, 800, 1000]);
  b.reset();
  assert.equal(b.next(), 100);
});
