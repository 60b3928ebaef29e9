// Tests web/interp.js: neighbour search and the render-strand instance layout.
import test from 'node:test';
import assert from 'node:assert/strict';
import { buildLayout, nearestTwo, rng, INSTANCE_FLOATS, INSTANCE_STRIDE } from '../../web/interp.js';

// roots on a sphere cap of radius 0.1 m (like a scalp), deterministic
function scalp(n, seed = 3) {
  const r = rng(seed), out = new Float32Array(3 * n);
  for (let i = 0; i < n; i++) {
    const z = 0.2 + 0.8 * r(), phi = 2 * Math.PI * r(), s = Math.sqrt(1 - z * z);
    out[3 * i] = 0.1 * s * Math.cos(phi); out[3 * i + 1] = 0.1 * z; out[3 * i + 2] = 0.1 * s * Math.sin(phi);
  }
  return out;
}

function brute(roots, n, i) {
  const d = [];
  for (let j = 0; j < n; j++) {
    if (j !== i) d.push([Math.hypot(roots[3 * j] - roots[3 * i], roots[3 * j + 1] - roots[3 * i + 1], roots[3 * j + 2] - roots[3 * i + 2]), j]);
  }
  d.sort((a, b) => a[0] - b[0] || a[1] - b[1]);
  return d;
}

test('nearestTwo agrees with brute force', () => {
  for (const n of [2, 3, 17, 500]) {
    const roots = scalp(n, n);
    const nb = nearestTwo(roots, n);
    for (let i = 0; i < n; i++) {
      const d = brute(roots, n, i);
      assert.ok(Math.abs(nb.d1[i] - d[0][0]) < 1e-7, `n ${n} point ${i} nearest`);
      if (n > 2) assert.ok(Math.abs(nb.d2[i] - d[1][0]) < 1e-7, `n ${n} point ${i} second`);
      else assert.equal(nb.n2[i], -1);
      assert.notEqual(nb.n1[i], i);
    }
  }
});

test('nearestTwo handles degenerate sets (one point, coincident and planar points)', () => {
  assert.equal(nearestTwo(new Float32Array(3), 1).n1[0], -1);
  const same = new Float32Array(12);
  const nb = nearestTwo(same, 4);
  for (let i = 0; i < 4; i++) { assert.equal(nb.d1[i], 0); assert.notEqual(nb.n1[i], i); assert.notEqual(nb.n2[i], -1); }
  const line = Float32Array.from([0, 0, 0, 1, 0, 0, 2, 0, 0, 10, 0, 0]);
  const nl = nearestTwo(line, 4);
  assert.deepEqual(Array.from(nl.n1), [1, 0, 1, 2]);
  assert.deepEqual(Array.from(nl.n2), [2, 2, 0, 1]);
});

test('layout: render strand 0 is the guide, weights and offsets stay in range', () => {
  const n = 300, per = 6, roots = scalp(n);
  const L = buildLayout(roots, n, per, { seed: 5 });
  assert.equal(L.count, n * per);
  assert.equal(L.data.byteLength, n * per * INSTANCE_STRIDE);
  const u32 = new Uint32Array(L.data), f32 = new Float32Array(L.data);
  const nb = nearestTwo(roots, n);
  let offsetSum = 0, blended = 0;
  for (let g = 0; g < n; g++) {
    for (let r = 0; r < per; r++) {
      const o = (g * per + r) * INSTANCE_FLOATS;
      assert.equal(u32[o], g);
      const b1 = f32[o + 3], b2 = f32[o + 4];
      assert.ok(b1 >= 0 && b2 >= 0 && b1 + b2 <= 1 + 1e-6);
      const off = Math.hypot(f32[o + 5], f32[o + 6]);
      assert.ok(off <= nb.d1[g] + 1e-7 || off <= 0.5 * L.spacing + 1e-7);
      assert.ok(f32[o + 7] > 0.8 && f32[o + 7] <= 1);
      assert.ok(f32[o + 8] >= 0 && f32[o + 8] < 1);
      if (r === 0) {
        assert.deepEqual([b1, b2, f32[o + 5], f32[o + 6], f32[o + 7]], [0, 0, 0, 0, 1]);
      } else {
        offsetSum += off;
        if (b1 > 0) { assert.equal(u32[o + 1], nb.n1[g]); blended++; }
        if (b2 > 0) assert.equal(u32[o + 2], nb.n2[g]);
      }
    }
  }
  assert.ok(offsetSum > 0, 'single-strand offsets are used');
  assert.ok(blended > n, 'multi-strand blending is used');
  // the median spacing is a nearest-neighbour distance
  assert.ok(L.spacing > 0 && L.spacing < 0.05);
});

test('layout: isolated guides do not blend with far neighbours', () => {
  // two tight clusters 1 m apart: no render strand may blend across
  const pts = [];
  for (let i = 0; i < 5; i++) pts.push(0.001 * i, 0, 0);
  for (let i = 0; i < 5; i++) pts.push(1 + 0.001 * i, 0, 0);
  pts.push(5, 5, 5); // a lone guide
  const roots = Float32Array.from(pts);
  const L = buildLayout(roots, 11, 8);
  const u32 = new Uint32Array(L.data), f32 = new Float32Array(L.data);
  for (let k = 0; k < L.count; k++) {
    const o = k * INSTANCE_FLOATS, g = u32[o];
    for (let j = 1; j <= 2; j++) {
      if (f32[o + 2 + j] > 0) assert.ok(Math.abs(roots[3 * u32[o + j]] - roots[3 * g]) < 0.01, `strand ${k} blends ${g} with ${u32[o + j]}`);
    }
    if (g === 10) {
      assert.deepEqual([f32[o + 3], f32[o + 4]], [0, 0]);
      assert.ok(Math.hypot(f32[o + 5], f32[o + 6]) <= 0.5 * L.spacing + 1e-7);
    }
  }
});

test('layout is deterministic for a seed and differs between seeds', () => {
  const roots = scalp(100);
  const a = new Uint8Array(buildLayout(roots, 100, 4, { seed: 9 }).data);
  const b = new Uint8Array(buildLayout(roots, 100, 4, { seed: 9 }).data);
  const c = new Uint8Array(buildLayout(roots, 100, 4, { seed: 10 }).data);
  assert.deepEqual(a, b);
  assert.notDeepEqual(a, c);
});

test('offsets spread evenly over the disc (mean squared radius = R^2 / 2)', () => {
  // one guide with a fixed nearest neighbour distance: disc radius = that distance
  const roots = Float32Array.from([0, 0, 0, 0.01, 0, 0, 0, 0.01, 0]);
  const per = 4000;
  const L = buildLayout(roots, 3, per, { seed: 2 });
  const f32 = new Float32Array(L.data);
  let ms = 0, mx = 0, my = 0;
  for (let r = 1; r < per; r++) {
    const o = r * INSTANCE_FLOATS;
    ms += f32[o + 5] ** 2 + f32[o + 6] ** 2; mx += f32[o + 5]; my += f32[o + 6];
  }
  ms /= per - 1; mx /= per - 1; my /= per - 1;
  assert.ok(Math.abs(ms / (0.01 ** 2 / 2) - 1) < 0.08, `mean squared radius ratio ${ms / (0.01 ** 2 / 2)}`);
  assert.ok(Math.abs(mx) < 0.0005 && Math.abs(my) < 0.0005);
});

test('guideData holds render strand 0 of every guide', () => {
  const roots = scalp(50);
  const L = buildLayout(roots, 50, 7);
  assert.equal(L.guideData.byteLength, 50 * INSTANCE_STRIDE);
  const all = new Uint8Array(L.data), g = new Uint8Array(L.guideData);
  for (let k = 0; k < 50; k++) {
    assert.deepEqual(g.subarray(k * INSTANCE_STRIDE, (k + 1) * INSTANCE_STRIDE), all.subarray(k * 7 * INSTANCE_STRIDE, (k * 7 + 1) * INSTANCE_STRIDE));
  }
});
