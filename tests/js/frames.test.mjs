// Tests web/frames.js: tangents and rotation-minimising normals (stored as coordinates in a
// basis rebuilt from the tangent), with temporal coherence at the root.
import test from 'node:test';
import assert from 'node:assert/strict';
import { strandFrames, tangentBasis } from '../../web/frames.js';

// positions of points given as [x, y, z] into the 4-float layout
function layout(points) {
  const pos = new Float32Array(4 * points.length);
  points.forEach((p, i) => pos.set(p, 4 * i));
  return pos;
}

function helix(n, turns, phase = 0) {
  const p = [];
  for (let i = 0; i < n; i++) {
    const a = phase + (2 * Math.PI * turns * i) / (n - 1);
    p.push([Math.cos(a) * 0.02, -0.01 * i, Math.sin(a) * 0.02]);
  }
  return p;
}

// the normal of point k as the shader rebuilds it
function normalAt(pos, tan, k) {
  const b = tangentBasis(new Float64Array(6), tan[4 * k], tan[4 * k + 1], tan[4 * k + 2]);
  const a = pos[4 * k + 3], c = tan[4 * k + 3];
  return [a * b[0] + c * b[3], a * b[1] + c * b[4], a * b[2] + c * b[5]];
}

function run(points, state = new Float32Array(3)) {
  const pos = layout(points), tan = new Float32Array(pos.length);
  strandFrames(pos, 0, tan, 0, 1, points.length, state, new Float64Array(6));
  return { pos, tan, state };
}

test('tangentBasis gives an orthonormal basis perpendicular to t, also near the poles', () => {
  for (const t of [[0, 0, 1], [0, 0, -1], [0, -1, 0], [0.6, 0, -0.8], [1e-9, 1, 0], [0.3, -0.4, Math.sqrt(0.75)]]) {
    const b = tangentBasis([0, 0, 0, 0, 0, 0], ...t);
    const b1 = b.slice(0, 3), b2 = b.slice(3);
    const dot = (u, v) => u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    assert.ok(Math.abs(dot(b1, b1) - 1) < 1e-9 && Math.abs(dot(b2, b2) - 1) < 1e-9, `${t}`);
    assert.ok(Math.abs(dot(b1, b2)) < 1e-9 && Math.abs(dot(b1, t)) < 1e-9 && Math.abs(dot(b2, t)) < 1e-9, `${t}`);
  }
});

test('tangents are unit central differences; the positions are kept', () => {
  const pts = helix(20, 1);
  const { pos, tan } = run(pts);
  for (let k = 0; k < 20; k++) {
    assert.deepEqual(Array.from(pos.slice(4 * k, 4 * k + 3)), Array.from(Float32Array.from(pts[k])));
    const a = pts[Math.max(0, k - 1)], c = pts[Math.min(19, k + 1)];
    const d = [c[0] - a[0], c[1] - a[1], c[2] - a[2]], l = Math.hypot(...d);
    for (let j = 0; j < 3; j++) assert.ok(Math.abs(tan[4 * k + j] - d[j] / l) < 1e-6);
  }
});

test('normals are unit length and perpendicular to the strand', () => {
  const { pos, tan } = run(helix(40, 1.5));
  for (let k = 0; k < 40; k++) {
    const n = normalAt(pos, tan, k);
    assert.ok(Math.abs(Math.hypot(...n) - 1) < 1e-5, `point ${k}`);
    assert.ok(Math.abs(n[0] * tan[4 * k] + n[1] * tan[4 * k + 1] + n[2] * tan[4 * k + 2]) < 1e-5, `point ${k}`);
  }
});

test('a straight strand gets one constant normal (no twist)', () => {
  const pts = [];
  for (let i = 0; i < 10; i++) pts.push([0.1 * i, 0.2 * i, 0]);
  const { pos, tan } = run(pts);
  const n0 = normalAt(pos, tan, 0);
  for (let k = 1; k < 10; k++) normalAt(pos, tan, k).forEach((v, j) => assert.ok(Math.abs(v - n0[j]) < 1e-6));
});

test('neighbouring normals change slowly along a curved strand', () => {
  const { pos, tan } = run(helix(64, 2));
  for (let k = 1; k < 64; k++) {
    const a = normalAt(pos, tan, k - 1), b = normalAt(pos, tan, k);
    assert.ok(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] > 0.9, `normals ${k - 1} and ${k}`);
  }
});

test('the root normal follows the previous frame instead of re-seeding', () => {
  const pts = [];
  for (let i = 0; i < 8; i++) pts.push([0, -0.01 * i, 0]); // hanging straight down
  const state = Float32Array.from([0, 0, 1]); // a previous normal along +z
  let r = run(pts, state);
  normalAt(r.pos, r.tan, 0).forEach((v, j) => assert.ok(Math.abs(v - [0, 0, 1][j]) < 1e-6));
  // tilt the strand a little: the normal tilts with it but keeps pointing mostly along +z
  r = run(pts.map((p, i) => [p[0], p[1], 0.002 * i]), state);
  const n = normalAt(r.pos, r.tan, 0);
  assert.ok(n[2] > 0.95, `root normal ${n}`);
  n.forEach((v, j) => assert.ok(Math.abs(v - state[j]) < 1e-5));
});

test('several strands at offsets each get their own frames', () => {
  const a = helix(5, 0.3), b = helix(5, 0.3, 1);
  const pos = new Float32Array(4 + 4 * 10), tan = new Float32Array(8 + 4 * 10).fill(7);
  [...a, ...b].forEach((p, i) => pos.set(p, 4 + 4 * i));
  strandFrames(pos, 4, tan, 8, 2, 5, new Float32Array(6), new Float64Array(6));
  assert.deepEqual(Array.from(tan.slice(0, 8)), Array(8).fill(7));
  for (let k = 0; k < 10; k++) {
    const t = tan.slice(8 + 4 * k, 11 + 4 * k);
    assert.ok(Math.abs(Math.hypot(...t) - 1) < 1e-6);
  }
});
