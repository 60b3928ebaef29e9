// Tests web/catmull.js: Catmull-Rom resampling of strands.
import test from 'node:test';
import assert from 'node:assert/strict';
import { catmullWeights, smoothStrands, smoothedCount } from '../../web/catmull.js';

function strand(points) { return Float32Array.from(points.flat()); }

test('weights sum to one and interpolate the control points at u = 0', () => {
  for (const segs of [1, 2, 3, 8]) {
    const w = catmullWeights(segs);
    for (let k = 0; k < segs; k++) {
      const sum = w[4 * k] + w[4 * k + 1] + w[4 * k + 2] + w[4 * k + 3];
      assert.ok(Math.abs(sum - 1) < 1e-6, `segs ${segs} k ${k} sum ${sum}`);
    }
    assert.deepEqual(Array.from(w.slice(0, 4)), [0, 1, 0, 0]);
  }
});

test('the smoothed strand passes through every control vertex', () => {
  const src = strand([[0, 0, 0], [1, 0.5, 0], [2, -0.3, 1], [3, 0, 2], [2.5, 1, 2.2]]);
  const segs = 4, pts = smoothedCount(5, segs);
  assert.equal(pts, 17);
  const dst = new Float32Array(3 * pts);
  smoothStrands(dst, 0, 3, src, 0, 1, 5, segs, catmullWeights(segs));
  for (let v = 0; v < 5; v++) {
    for (let c = 0; c < 3; c++) assert.ok(Math.abs(dst[3 * v * segs + c] - src[3 * v + c]) < 1e-6);
  }
});

test('a straight evenly spaced strand stays straight and evenly spaced', () => {
  const src = strand([[0, 0, 0], [0, -1, 0], [0, -2, 0], [0, -3, 0]]);
  const segs = 3, pts = smoothedCount(4, segs);
  const dst = new Float32Array(3 * pts);
  smoothStrands(dst, 0, 3, src, 0, 1, 4, segs, catmullWeights(segs));
  for (let i = 0; i < pts; i++) {
    assert.ok(Math.abs(dst[3 * i]) < 1e-6 && Math.abs(dst[3 * i + 2]) < 1e-6);
    assert.ok(Math.abs(dst[3 * i + 1] + i / segs) < 1e-5, `point ${i}: ${dst[3 * i + 1]}`);
  }
});

test('the curve is smooth: a midpoint matches the uniform Catmull-Rom formula', () => {
  const P = [[0, 0, 0], [1, 2, 0], [3, 3, 1], [4, 1, 2]];
  const src = strand(P);
  const dst = new Float32Array(3 * smoothedCount(4, 2));
  smoothStrands(dst, 0, 3, src, 0, 1, 4, 2, catmullWeights(2));
  // midpoint of span 1 (between P1 and P2): (-P0 + 9 P1 + 9 P2 - P3) / 16
  for (let c = 0; c < 3; c++) {
    const want = (-P[0][c] + 9 * P[1][c] + 9 * P[2][c] - P[3][c]) / 16;
    assert.ok(Math.abs(dst[3 * 3 + c] - want) < 1e-6);
  }
});

test('several strands with offsets and a stride of 4 keep to their own slots', () => {
  const a = [[0, 0, 0], [0, 1, 0], [0, 2, 0]], b = [[5, 0, 0], [5, 1, 1], [5, 2, 2]];
  const src = Float32Array.from([9, 9, 9, ...a.flat(), ...b.flat()]);
  const segs = 2, pts = smoothedCount(3, segs);
  const dst = new Float32Array(8 + 2 * 4 * pts).fill(-7);
  smoothStrands(dst, 8, 4, src, 3, 2, 3, segs, catmullWeights(segs));
  assert.deepEqual(Array.from(dst.slice(0, 8)), Array(8).fill(-7));
  assert.deepEqual(Array.from(dst.slice(8, 12)), [0, 0, 0, -7], 'the fourth slot is left alone');
  assert.deepEqual(Array.from(dst.slice(12, 15)), [0, 0.5, 0]);
  assert.deepEqual(Array.from(dst.slice(8 + 4 * pts, 12 + 4 * pts)), [5, 0, 0, -7]);
  assert.deepEqual(Array.from(dst.slice(8 + 4 * (2 * pts - 1))), [5, 2, 2, -7]);
});
