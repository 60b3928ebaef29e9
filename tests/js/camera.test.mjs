// Tests web/camera.js and web/mat4.js: orbit camera matrices, rays, framing; matrix helpers.
import test from 'node:test';
import assert from 'node:assert/strict';
import { OrbitCamera } from '../../web/camera.js';
import { mat3NormalFromMat4, mat4FromTRS, mat4Invert, mat4Multiply, mat4TransformPoint, quatAxisAngle, quatRotate } from '../../web/mat4.js';

const close = (a, b, eps = 1e-5) => Math.abs(a - b) <= eps;

test('the target projects to the centre of the screen and the eye sits at the distance', () => {
  const cam = new OrbitCamera({ yaw: 0.7, pitch: 0.3, distance: 2, target: [0.1, 0.2, -0.3] });
  cam.update(16 / 9);
  const p = mat4TransformPoint([0, 0, 0], cam.viewProj, cam.target);
  assert.ok(close(p[0], 0) && close(p[1], 0) && p[2] > -1 && p[2] < 1);
  const d = Math.hypot(cam.eye[0] - 0.1, cam.eye[1] - 0.2, cam.eye[2] + 0.3);
  assert.ok(close(d, 2));
  // basis is orthonormal and right-handed (right x up = -forward)
  const { right: r, up: u, forward: f } = cam;
  assert.ok(close(r[0] * u[0] + r[1] * u[1] + r[2] * u[2], 0));
  assert.ok(close(r[0] * f[0] + r[1] * f[1] + r[2] * f[2], 0));
  assert.ok(close(r[1] * u[2] - r[2] * u[1], -f[0]) && close(r[0] * u[1] - r[1] * u[0], -f[2]));
});

test('a point to the camera right appears on the right, one above appears above', () => {
  const cam = new OrbitCamera({ yaw: -1.1, pitch: -0.2, distance: 1 });
  cam.update(1);
  const pr = mat4TransformPoint([0, 0, 0], cam.viewProj, [0.1 * cam.right[0], 0.1 * cam.right[1], 0.1 * cam.right[2]]);
  const pu = mat4TransformPoint([0, 0, 0], cam.viewProj, [0.1 * cam.up[0], 0.1 * cam.up[1], 0.1 * cam.up[2]]);
  assert.ok(pr[0] > 0.1 && close(pr[1], 0));
  assert.ok(pu[1] > 0.1 && close(pu[0], 0));
});

test('orbit clamps pitch short of the poles; zoom stays within limits', () => {
  const cam = new OrbitCamera();
  cam.orbit(0, 1e6);
  assert.ok(cam.pitch < Math.PI / 2 && cam.pitch > 1.5);
  cam.orbit(0, -1e7);
  assert.ok(cam.pitch > -Math.PI / 2 && cam.pitch < -1.5);
  cam.update(1);
  assert.ok(cam.viewProj.every(Number.isFinite));
  const yaw = cam.yaw;
  cam.orbit(100, 0);
  assert.ok(!close(cam.yaw, yaw));
  cam.zoom(1e-9);
  assert.equal(cam.distance, cam.minDistance);
  cam.zoom(1e9);
  assert.equal(cam.distance, cam.maxDistance);
  cam.zoom(NaN);
  cam.zoom(-1);
  assert.equal(cam.distance, cam.maxDistance);
});

test('rays through the screen centre hit the target; rays go through their pixel', () => {
  const cam = new OrbitCamera({ yaw: 2, pitch: 0.4, distance: 3, target: [1, 0, 0] });
  cam.update(1.5);
  const o = [0, 0, 0], d = [0, 0, 0];
  cam.ray(0, 0, o, d);
  const t = 3;
  for (let c = 0; c < 3; c++) assert.ok(close(o[c] + t * d[c], cam.target[c], 1e-4));
  cam.ray(0.5, -0.25, o, d);
  const p = mat4TransformPoint([0, 0, 0], cam.viewProj, [o[0] + 2 * d[0], o[1] + 2 * d[1], o[2] + 2 * d[2]]);
  assert.ok(close(p[0], 0.5, 1e-4) && close(p[1], -0.25, 1e-4));
});

test('frame() fits a bounding box in view', () => {
  const cam = new OrbitCamera();
  cam.frame([-0.1, 0, -0.1, 0.1, 0.3, 0.1]);
  assert.deepEqual(Array.from(cam.target).map((x) => +x.toFixed(6)), [0, 0.15, 0]);
  cam.update(1);
  for (const x of [-0.1, 0.1]) for (const y of [0, 0.3]) for (const z of [-0.1, 0.1]) {
    const p = mat4TransformPoint([0, 0, 0], cam.viewProj, [x, y, z]);
    assert.ok(Math.abs(p[0]) < 1 && Math.abs(p[1]) < 1, `corner ${x},${y},${z} off screen`);
  }
});

test('mat4 helpers: TRS, inverse, normal matrix, quaternion rotation', () => {
  const q = quatAxisAngle([0, 0, 0, 1], [0, 1, 0], Math.PI / 2);
  const v = quatRotate([0, 0, 0], q, [1, 0, 0]);
  assert.ok(close(v[0], 0) && close(v[2], -1));
  const m = mat4FromTRS(new Float32Array(16), [1, 2, 3], q, [2, 3, 4]);
  const p = mat4TransformPoint([0, 0, 0], m, [1, 0, 0]);
  assert.ok(close(p[0], 1) && close(p[1], 2) && close(p[2], 1));
  const inv = new Float32Array(16), id = new Float32Array(16);
  assert.ok(mat4Invert(inv, m));
  mat4Multiply(id, m, inv);
  for (let i = 0; i < 16; i++) assert.ok(close(id[i], i % 5 === 0 ? 1 : 0));
  assert.equal(mat4Invert(inv, new Float32Array(16)), false);
  // normals of a scaled sphere: the normal matrix maps (1,0,0) of the unit sphere to x / sx^2
  const n = mat3NormalFromMat4(new Float32Array(9), mat4FromTRS(new Float32Array(16), [0, 0, 0], [0, 0, 0, 1], [2, 1, 1]));
  assert.ok(close(n[0], 0.5) && close(n[4], 1) && close(n[8], 1) && close(n[1], 0));
  // and for a rotation it is the rotation itself
  const nr = mat3NormalFromMat4(new Float32Array(9), m.map((x, i) => (i === 12 || i === 13 || i === 14 ? 0 : x)));
  const axis = [nr[0] * 1, nr[1] * 1, nr[2] * 1]; // column 0 = image of +x, scaled by 1/2
  assert.ok(close(axis[0], 0) && close(axis[2], -0.5));
});
