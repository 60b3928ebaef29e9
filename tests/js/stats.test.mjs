// Tests web/stats.js: windowed rates, moving average and the latency estimate.
import test from 'node:test';
import assert from 'node:assert/strict';
import { Ema, LatencyEstimator, RateMeter } from '../../web/stats.js';

test('RateMeter: steady 60 Hz events of 1000 bytes', () => {
  const m = new RateMeter(1000);
  let t = 0;
  for (let i = 0; i < 600; i++) { t = i * (1000 / 60); m.add(t, 1000); }
  assert.ok(Math.abs(m.perSecond(t) - 60) <= 1.5, `rate ${m.perSecond(t)}`);
  assert.ok(Math.abs(m.bytesPerSecond(t) - 60000) <= 1500);
  // nothing arrives for 2 s: the rate drops to zero
  assert.equal(m.perSecond(t + 2000), 0);
  m.reset();
  assert.equal(m.perSecond(t), 0);
});

test('RateMeter: young meters and full rings still give the right rate', () => {
  const m = new RateMeter(1000);
  for (let i = 0; i <= 10; i++) m.add(i * 20, 1); // 50 Hz for 200 ms
  assert.ok(Math.abs(m.perSecond(200) - 55) < 6, `young rate ${m.perSecond(200)}`);
  const small = new RateMeter(1000, 16);
  let t = 0;
  for (let i = 0; i < 200; i++) { t = i; small.add(t, 1); } // 1000 Hz into a 16-slot ring
  assert.ok(Math.abs(small.perSecond(t) - 1000) < 100, `full-ring rate ${small.perSecond(t)}`);
});

test('Ema converges and starts from the first sample', () => {
  const e = new Ema(0.5);
  assert.equal(e.add(10), 10);
  assert.equal(e.add(20), 15);
  for (let i = 0; i < 50; i++) e.add(4);
  assert.ok(Math.abs(e.value - 4) < 1e-9);
});

test('LatencyEstimator: extra delay over the fastest frame is measured', () => {
  const L = new LatencyEstimator(10000);
  const offset = 123456; // arbitrary clock offset between wall and sim clocks
  for (let i = 0; i < 100; i++) L.add(offset + i * 16 + 5, i * 0.016);
  assert.ok(Math.abs(L.value) < 1e-6);
  const v = L.add(offset + 100 * 16 + 5 + 40, 100 * 0.016);
  assert.ok(Math.abs(v - 40) < 3, `latency ${v}`);
  // a reset of sim time restarts the estimate instead of reporting a huge latency
  assert.ok(Math.abs(L.add(offset + 5000, 0)) < 1e-6);
  assert.ok(Number.isNaN(new LatencyEstimator().add(0, NaN)));
});

test('LatencyEstimator: a server slower than real time is not mistaken for latency', () => {
  const L = new LatencyEstimator(5000);
  // the sim advances 1/60 s per step but only 20 steps happen per wall second
  let v = 0;
  for (let i = 0; i < 200; i++) v = L.add(1000 + i * 50 + (i % 7 === 0 ? 3 : 0), i / 60);
  assert.ok(v < 5, `latency ${v} ms`);
  assert.ok(Math.abs(L.rate - 1 / 3) < 0.01, `rate ${L.rate}`);
  // one frame 30 ms late shows as 30 ms
  v = L.add(1000 + 200 * 50 + 30, 200 / 60);
  assert.ok(Math.abs(v - 30) < 4, `late frame ${v}`);
});
