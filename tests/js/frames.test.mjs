// Tests web/frames.js: rotation-minimising strand normals with temporal coherence at the root.
import test from 'node:test';
import assert from 'node:assert/strict';
import { strandNormals } from '../../web/frames.js';

function helix(n, turns, phase = 0) {
  const p = [];
  for (let i = 0; i < n; i++) {
    const a = phase + (2 * Math.PI * turns * i) / (n - 1);
    p.push(Math.cos(a) * 0.02, -0.01 * i, Math.sin(a) * 0.02);
  }
  return Float32Array.from(p);
}

function tangent(pos, i, n) {
  const a = Math.max(0, i - 1), b = Math.min(n - 1, i + 1);
  const t = [pos[3 * b] - pos[3 * a], pos[3 * b + 1] - pos[3 * a + 1], pos[3 * b + 2] - pos[3 * a + 2]];
  const l = Math.hypot(...t);
  return t.map((x) => x / l);
}

test('normals are unit length and perpendicular to the strand', () => {
  const n = 40, pos = helix(n, 1.5);
  const nrm = new Float32Array(3 * n), state = new Float32Array(3);
  strandNormals(nrm, 0, pos, 0, 1, n, state);
  for (let i = 1; i < n; i++) {
    const v = [nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]];
    assert.ok(Math.abs(Math.hypot(...v) - 1) < 1e-5);
    const t = tangent(pos, i, n);
    assert.ok(Math.abs(v[0] * t[0] + v[1] * t[1] + v[2] * t[2]) < 1e-4, `point ${i}`);
  }
});

test('a straight strand gets one constant normal (no twist)', () => {
  const n = 10, pos = new Float32Array(3 * n);
  for (let i = 0; i < n; i++) { pos[3 * i] = 0.1 * i; pos[3 * i + 1] = 0.2 * i; }
  const nrm = new Float32Array(3 * n), state = new Float32Array(3);
  strandNormals(nrm, 0, pos, 0, 1, n, state);
  for (let i = 1; i < n; i++) {
    for (let c = 0; c < 3; c++) assert.ok(Math.abs(nrm[3 * i + c] - nrm[c]) < 1e-6);
  }
});

test('neighbouring normals change slowly along a curved strand', () => {
  const n = 64, pos = helix(n, 2);
  const nrm = new Float32Array(3 * n), state = new Float32Array(3);
  strandNormals(nrm, 0, pos, 0, 1, n, state);
  for (let i = 1; i < n; i++) {
    const d = nrm[3 * i] * nrm[3 * i - 3] + nrm[3 * i + 1] * nrm[3 * i - 2] + nrm[3 * i + 2] * nrm[3 * i - 1];
    assert.ok(d > 0.9, `normals ${i - 1} and ${i} differ: dot ${d}`);
  }
});

test('the root normal follows the previous frame instead of re-seeding', () => {
  const n = 8, pos = new Float32Array(3 * n);
  for (let i = 0; i < n; i++) pos[3 * i + 1] = -0.01 * i; // hanging straight down
  const nrm = new Float32Array(3 * n);
  const state = Float32Array.from([0, 0, 1]); // a previous normal along +z
  strandNormals(nrm, 0, pos, 0, 1, n, state);
  assert.deepEqual(Array.from(nrm.slice(0, 3)), [0, 0, 1]);
  // tilt the strand a little: the normal tilts with it but keeps pointing mostly along +z
  for (let i = 0; i < n; i++) pos[3 * i + 2] = 0.002 * i;
  strandNormals(nrm, 0, pos, 0, 1, n, state);
  assert.ok(nrm[2] > 0.95, `root normal z ${nrm[2]}`);
  assert.deepEqual(Array.from(state), Array.from(nrm.slice(0, 3)));
});

test('offsets select the strand slots', () => {
  const n = 5, a = helix(n, 0.3), b = helix(n, 0.3, 1);
  const pos = Float32Array.from([1, 2, 3, ...a, ...b]);
  const nrm = new Float32Array(6 + 6 * n).fill(7), state = new Float32Array(6);
  strandNormals(nrm, 6, pos, 3, 2, n, state);
  assert.deepEqual(Array.from(nrm.slice(0, 6)), [7, 7, 7, 7, 7, 7]);
  for (let i = 0; i < 2 * n; i++) assert.ok(Math.abs(Math.hypot(nrm[6 + 3 * i], nrm[7 + 3 * i], nrm[8 + 3 * i]) - 1) < 1e-5);
});
