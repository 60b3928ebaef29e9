// Tests web/overlay.js: the stats overlay text.
import test from 'node:test';
import assert from 'node:assert/strict';
import { statsText } from '../../web/overlay.js';

const snap = {
  renderFps: 59.94, framesPerSec: 60, seq: 1234, kbitPerSec: 2380.4, bytesPerVertex: 0.3791, latencyMs: 4.25,
  decodeMs: 1.5, prepareMs: 2.25, uploadMs: 0.75, serverStepsPerSec: 59.9, serverStepMs: 6.3, clients: 2,
  guides: 4096, verts: 32, renderStrands: 16384, paused: false, renderer: 'ANGLE (Google, Vulkan 1.3.0 (SwiftShader Device (Subzero)))', antialias: false,
};

test('every figure of the overlay is shown with its unit', () => {
  const t = statsText(snap);
  for (const want of ['59.9 fps', '60.0 /s', 'seq 1234', '2380 kbit/s', '0.38 B/vertex', '4.3 ms', '1.50 ms + 2.25 ms smooth', 'upload 0.75 ms',
    '59.9 steps/s', 'step 6.30 ms', 'clients 2', '4096 guides × 32 → 16384 strands', '(no MSAA)']) {
    assert.ok(t.includes(want), `missing "${want}" in\n${t}`);
  }
  assert.ok(!t.includes('paused'));
  assert.ok(t.split('\n').every((line) => line.length <= 80));
});

test('missing figures show a dash, pause is flagged', () => {
  const t = statsText({ ...snap, latencyMs: NaN, serverStepsPerSec: undefined, seq: null, clients: undefined, paused: true, antialias: true, renderer: 'GPU' });
  assert.match(t, /latency {2}— ms/);
  assert.match(t, /server {3}— steps\/s/);
  assert.match(t, /seq —/);
  assert.match(t, /paused/);
  assert.match(t, /webgl {4}GPU$/m);
});
