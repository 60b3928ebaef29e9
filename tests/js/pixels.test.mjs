// Tests tests/e2e/pixels.mjs: the e2e test's hair-pixel, shading and change measures.
import test from 'node:test';
import assert from 'node:assert/strict';
import { diffShare, isHair, pixelStats } from '../e2e/pixels.mjs';

function image(pixels) { return Uint8Array.from(pixels.flat()); }

test('brown hair counts as hair; background, grey-blue head and white do not', () => {
  assert.ok(isHair(138, 90, 50));
  assert.ok(isHair(70, 45, 25));
  for (const p of [[19, 21, 26], [128, 135, 153], [250, 250, 250], [40, 40, 40]]) assert.ok(!isHair(...p), `${p}`);
});

test('pixelStats measures hair share, hair shading spread and overall contrast', () => {
  const bg = [19, 21, 26, 255];
  const flat = image([...Array(90).fill(bg), ...Array(10).fill([138, 90, 50, 255])]);
  const s = pixelStats(flat);
  assert.ok(Math.abs(s.hairShare - 0.1) < 1e-9);
  assert.equal(s.hairLumaSpread, 0);
  assert.ok(s.lumaStd > 10);
  const shaded = image([...Array(50).fill(bg), ...Array.from({ length: 50 }, (_, i) => [60 + 3 * i, 40 + 2 * i, 20 + i, 255])]);
  assert.ok(pixelStats(shaded).hairLumaSpread > 60);
  assert.equal(pixelStats(image(Array(10).fill(bg))).lumaStd, 0);
});

test('diffShare counts pixels that changed by more than the threshold', () => {
  const a = image(Array(100).fill([10, 10, 10, 255]));
  const b = Uint8Array.from(a);
  assert.equal(diffShare(a, b, 5), 0);
  for (let i = 0; i < 7; i++) b[4 * i + 1] = 200;
  b[4 * 50] = 14; // below the threshold
  assert.ok(Math.abs(diffShare(a, b, 5) - 0.07) < 1e-9);
  assert.equal(diffShare(a, b.subarray(4), 5), 1);
});
