// Tests web/geometry.js: collider meshes and the placement of collider parts.
import test from 'node:test';
import assert from 'node:assert/strict';
import { colliderParts, unitCylinder, unitSphere } from '../../web/geometry.js';
import { mat4FromTRS, mat4TransformPoint } from '../../web/mat4.js';

const close = (a, b, eps = 1e-5) => Math.abs(a - b) <= eps;

test('unit sphere: every vertex on the sphere, indices in range', () => {
  const m = unitSphere(8, 16);
  for (let i = 0; i < m.positions.length; i += 3) assert.ok(close(Math.hypot(m.positions[i], m.positions[i + 1], m.positions[i + 2]), 1));
  assert.ok(m.indices.every((k) => k < m.positions.length / 3));
  assert.equal(m.indices.length, 8 * 16 * 6);
});

test('unit cylinder: radius 1, y in [0, 1], radial normals', () => {
  const m = unitCylinder(12);
  for (let i = 0; i < m.positions.length; i += 3) {
    assert.ok(close(Math.hypot(m.positions[i], m.positions[i + 2]), 1));
    assert.ok(m.positions[i + 1] === 0 || m.positions[i + 1] === 1);
    assert.ok(close(m.normals[i], m.positions[i]) && m.normals[i + 1] === 0);
  }
  assert.ok(m.indices.every((k) => k < m.positions.length / 3));
});

test('a capsule becomes two end spheres and a cylinder from a to b', () => {
  const parts = colliderParts({ kind: 'capsule', a: [0.1, -0.2, 0], b: [0.3, -0.2, 0.1], radius: 0.05 });
  assert.deepEqual(parts.map((p) => p.mesh), ['sphere', 'sphere', 'cylinder']);
  const cyl = parts[2];
  const m = mat4FromTRS(new Float32Array(16), cyl.t, cyl.q, cyl.s);
  const top = mat4TransformPoint([0, 0, 0], m, [0, 1, 0]);
  [0.3, -0.2, 0.1].forEach((v, c) => assert.ok(close(top[c], v), `top ${top}`));
  const side = mat4TransformPoint([0, 0, 0], m, [1, 0, 0]);
  assert.ok(close(Math.hypot(side[0] - 0.1, side[1] + 0.2, side[2]), 0.05));
  // a capsule pointing straight down (the antiparallel case)
  const down = colliderParts({ kind: 'capsule', a: [0, 0, 0], b: [0, -1, 0], radius: 0.1 })[2];
  const md = mat4FromTRS(new Float32Array(16), down.t, down.q, down.s);
  assert.ok(close(mat4TransformPoint([0, 0, 0], md, [0, 1, 0])[1], -1));
});

test('spheres and ellipsoids map the unit sphere; bad colliders give nothing', () => {
  assert.deepEqual(colliderParts({ kind: 'sphere', center: [1, 2, 3], radius: 0.5 })[0].s, [0.5, 0.5, 0.5]);
  const e = colliderParts({ kind: 'ellipsoid', center: [0, 0, 0], radii: [0.1, 0.12, 0.09] })[0];
  assert.deepEqual(e.q, [0, 0, 0, 1]);
  for (const bad of [null, {}, { kind: 'cone' }, { kind: 'sphere', center: [0, 0], radius: 1 }, { kind: 'sphere', center: [0, 0, 0], radius: -1 },
    { kind: 'ellipsoid', center: [0, 0, 0], radii: [1, 0, 1] }, { kind: 'capsule', a: [0, 0, NaN], b: [0, 0, 0], radius: 1 }]) {
    assert.deepEqual(colliderParts(bad), [], JSON.stringify(bad));
  }
});
