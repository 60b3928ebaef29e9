// Tests web/rigid.js: the head pose recovered from moved, noisy strand roots.
import test from 'node:test';
import assert from 'node:assert/strict';
import { fitRigid, rigidScratch } from '../../web/rigid.js';
import { quatAxisAngle, quatRotate, quatNormalize } from '../../web/mat4.js';
import { rng } from '../../web/interp.js';

function scalpRoots(n, seed) {
  const r = rng(seed), out = new Float32Array(3 * n);
  for (let i = 0; i < n; i++) {
    const z = 0.1 + 0.9 * r(), phi = 2 * Math.PI * r(), s = Math.sqrt(1 - z * z);
    out[3 * i] = 0.09 * s * Math.cos(phi); out[3 * i + 1] = 0.05 + 0.1 * z; out[3 * i + 2] = 0.1 * s * Math.sin(phi);
  }
  return out;
}

// strand-major frame with pts points per strand whose roots are the moved rest roots
function frame(rest, n, pts, q, t, noise, seed) {
  const r = rng(seed), out = new Float32Array(3 * n * pts).fill(99);
  const p = [0, 0, 0];
  for (let i = 0; i < n; i++) {
    quatRotate(p, q, [rest[3 * i], rest[3 * i + 1], rest[3 * i + 2]]);
    for (let c = 0; c < 3; c++) out[3 * i * pts + c] = p[c] + t[c] + noise * (2 * r() - 1);
  }
  return out;
}

test('recovers rotation and translation from moved roots', () => {
  const n = 500, pts = 7, rest = scalpRoots(n, 4);
  const axis = [0.3, 0.9, -0.3], l = Math.hypot(...axis);
  for (const angle of [0, 0.2, 1.5, 3.0]) {
    const q = quatAxisAngle([0, 0, 0, 1], axis.map((a) => a / l), angle), t = [0.1, -0.05, 0.3];
    const cur = frame(rest, n, pts, q, t, 1e-4, 7);
    const out = { q: [0, 0, 0, 1], t: [0, 0, 0] };
    assert.ok(fitRigid(out, rest, cur, 0, 3 * pts, n, 3, rigidScratch()));
    const dot = Math.abs(out.q[0] * q[0] + out.q[1] * q[1] + out.q[2] * q[2] + out.q[3] * q[3]);
    assert.ok(1 - dot < 1e-5, `angle ${angle}: quaternion off by ${1 - dot}`);
    for (let c = 0; c < 3; c++) assert.ok(Math.abs(out.t[c] - t[c]) < 5e-4, `angle ${angle}: t ${out.t}`);
  }
});

test('keeps the quaternion sign near the previous one and uses the offset', () => {
  const n = 200, rest = scalpRoots(n, 2);
  const q = quatNormalize([0, 0, 0, 0], [0.1, 0.2, 0.3, -0.9]);
  const cur = Float32Array.from([5, 5, ...frame(rest, n, 1, q, [0, 0, 0], 0, 1)]);
  const out = { q: [-q[0], -q[1], -q[2], -q[3]], t: [0, 0, 0] };
  assert.ok(fitRigid(out, rest, cur, 2, 3, n, 1, rigidScratch()));
  assert.ok(out.q[3] > 0.85, `sign follows the previous estimate: ${out.q}`);
});

test('refuses too few or collinear roots and leaves the pose alone', () => {
  const out = { q: [0, 0, 0, 1], t: [1, 2, 3] };
  const two = Float32Array.from([0, 0, 0, 1, 0, 0]);
  assert.equal(fitRigid(out, two, two, 0, 3, 2, 1, rigidScratch()), false);
  const line = Float32Array.from([0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0]);
  assert.equal(fitRigid(out, line, line, 0, 3, 4, 1, rigidScratch()), false);
  const same = new Float32Array(12);
  assert.equal(fitRigid(out, same, same, 0, 3, 4, 1, rigidScratch()), false);
  assert.deepEqual(out, { q: [0, 0, 0, 1], t: [1, 2, 3] });
});
