// Tests web/pick.js: ray casts against spheres, capsules, ellipsoids and a moved head.
import test from 'node:test';
import assert from 'node:assert/strict';
import { pickColliders, rayCapsule, rayEllipsoid, raySphere } from '../../web/pick.js';
import { quatAxisAngle } from '../../web/mat4.js';

const close = (a, b, eps = 1e-6) => Math.abs(a - b) <= eps;

test('sphere: front hit, miss, and a ray starting inside', () => {
  assert.ok(close(raySphere([0, 0, 5], [0, 0, -1], [0, 0, 0], 1), 4));
  assert.equal(raySphere([0, 2, 5], [0, 0, -1], [0, 0, 0], 1), -1);
  assert.equal(raySphere([0, 0, 5], [0, 0, 1], [0, 0, 0], 1), -1);
  assert.ok(close(raySphere([0, 0, 0], [1, 0, 0], [0, 0, 0], 1), 1));
});

test('capsule: body, caps and misses', () => {
  const a = [0, -1, 0], b = [0, 1, 0];
  assert.ok(close(rayCapsule([5, 0.5, 0], [-1, 0, 0], a, b, 0.5), 4.5));
  assert.ok(close(rayCapsule([0, 5, 0], [0, -1, 0], a, b, 0.5), 3.5));
  assert.ok(close(rayCapsule([5, -1.2, 0], [-1, 0, 0], a, b, 0.5), 5 - Math.sqrt(0.25 - 0.04)));
  assert.equal(rayCapsule([5, 2, 0], [-1, 0, 0], a, b, 0.5), -1);
});

test('ellipsoid: axes and rotation', () => {
  const id = [0, 0, 0, 1];
  assert.ok(close(rayEllipsoid([5, 0, 0], [-1, 0, 0], [0, 0, 0], [2, 1, 1], id), 3));
  assert.ok(close(rayEllipsoid([0, 5, 0], [0, -1, 0], [0, 0, 0], [2, 1, 1], id), 4));
  const q = quatAxisAngle([0, 0, 0, 1], [0, 0, 1], Math.PI / 2); // long axis now along y
  assert.ok(close(rayEllipsoid([0, 5, 0], [0, -1, 0], [0, 0, 0], [2, 1, 1], q), 3, 1e-5));
  assert.equal(rayEllipsoid([0, 5, 0], [0, -1, 0], [0, 0, 0], [0, 1, 1], id), -1);
});

test('pickColliders uses the head transform and returns the nearest hit', () => {
  const colliders = [
    { kind: 'ellipsoid', center: [0, 0, 0], radii: [0.1, 0.12, 0.1], rotation: [0, 0, 0, 1] },
    { kind: 'sphere', center: [0, 0, 0.2], radius: 0.05 },
    { kind: 'capsule', a: [0, -0.3, 0], b: [0, -0.15, 0], radius: 0.05 },
  ];
  const head = { position: [1, 0, 0], orientation: [0, 0, 0, 1] };
  assert.ok(close(pickColliders([1, 0, 1], [0, 0, -1], colliders, head), 0.75));
  assert.equal(pickColliders([0, 0, 1], [0, 0, -1], colliders, head), -1);
  assert.ok(close(pickColliders([1, -0.2, 1], [0, 0, -1], colliders, head), 0.95));
  // turn the head 90 degrees about y: the sphere on +z moves to +x
  const turned = { position: [1, 0, 0], orientation: quatAxisAngle([0, 0, 0, 1], [0, 1, 0], Math.PI / 2) };
  assert.ok(close(pickColliders([2, 0, 0], [-1, 0, 0], colliders, turned), 0.75, 1e-6));
  assert.ok(close(pickColliders([1, 0, 1], [0, 0, -1], colliders, turned), 0.9, 1e-6));
});
