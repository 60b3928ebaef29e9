// Tests web/motion.js: head drags become translations, rotations and motion messages.
import test from 'node:test';
import assert from 'node:assert/strict';
import { dragRotate, dragTranslate, motionMessage } from '../../web/motion.js';
import { quatRotate } from '../../web/mat4.js';

const close = (a, b, eps = 1e-6) => Math.abs(a - b) <= eps;

test('dragging right and down moves along camera right and down', () => {
  const out = dragTranslate([0, 0, 0], [1, 2, 3], [1, 0, 0], [0, 1, 0], 10, 20, 0.001);
  assert.ok(close(out[0], 1.01) && close(out[1], 1.98) && close(out[2], 3));
  const tilted = dragTranslate([0, 0, 0], [0, 0, 0], [0, 0, -1], [0, 1, 0], 100, 0, 0.01);
  assert.ok(close(tilted[2], -1));
});

test('horizontal drags turn the head about the camera up axis, vertical about right', () => {
  const right = [1, 0, 0], up = [0, 1, 0];
  const q = dragRotate([0, 0, 0, 1], [0, 0, 0, 1], right, up, 100, 0, Math.PI / 200);
  const v = quatRotate([0, 0, 0], q, [0, 0, 1]);
  assert.ok(close(v[0], 1, 1e-6) && close(v[2], 0, 1e-6), `yaw result ${v}`);
  const p = dragRotate([0, 0, 0, 1], [0, 0, 0, 1], right, up, 0, 100, Math.PI / 200);
  const w = quatRotate([0, 0, 0], p, [0, 0, 1]);
  assert.ok(close(w[1], -1, 1e-6), `pitch result ${w}`);
  assert.ok(close(Math.hypot(...p), 1));
  // composes with the starting orientation
  const twice = dragRotate([0, 0, 0, 1], q, right, up, 100, 0, Math.PI / 200);
  const u = quatRotate([0, 0, 0], twice, [0, 0, 1]);
  assert.ok(close(u[2], -1, 1e-6));
});

test('motionMessage has the protocol shape with copied plain arrays', () => {
  const pos = new Float64Array([1, 2, 3]), q = new Float32Array([0, 0, 0, 1]);
  const m = motionMessage(12.5, pos, q);
  assert.deepEqual(m, { type: 'motion', t: 12.5, position: [1, 2, 3], orientation: [0, 0, 0, 1] });
  assert.equal(JSON.stringify(m), '{"type":"motion","t":12.5,"position":[1,2,3],"orientation":[0,0,0,1]}');
});
