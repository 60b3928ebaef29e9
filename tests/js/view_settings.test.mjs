// Tests web/view_settings.js: viewer defaults, validated changes, colours and light direction.
import test from 'node:test';
import assert from 'node:assert/strict';
import { VIEW_SPECS, applySetting, defaultSettings, hexToLinear, lightDirection } from '../../web/view_settings.js';

test('every spec has a default inside its range', () => {
  const s = defaultSettings();
  for (const spec of VIEW_SPECS) {
    assert.ok(spec.name in s);
    if (spec.kind === 'float' || spec.kind === 'int') assert.ok(spec.def >= spec.min && spec.def <= spec.max, spec.name);
  }
  assert.equal(s.perGuide, 4);
  assert.deepEqual(s.hairColorLinear, hexToLinear(s.hairColor));
});

test('applySetting clamps, rounds, validates and names what must be rebuilt', () => {
  const s = defaultSettings();
  assert.equal(applySetting(s, 'perGuide', 16.4), 'layout');
  assert.equal(s.perGuide, 16);
  assert.equal(applySetting(s, 'perGuide', 1e6), 'layout');
  assert.equal(s.perGuide, 32);
  assert.equal(applySetting(s, 'segs', 3), 'smoothing');
  assert.equal(applySetting(s, 'multi', 0.25), undefined);
  assert.equal(s.multi, 0.25);
  assert.equal(applySetting(s, 'multi', 'x'), null);
  assert.equal(s.multi, 0.25);
  assert.equal(applySetting(s, 'shadows', 'yes'), null);
  assert.equal(applySetting(s, 'shadows', false), undefined);
  assert.equal(s.shadows, false);
  assert.equal(applySetting(s, 'hairColor', '#ffffff'), undefined);
  assert.deepEqual(s.hairColorLinear, [1, 1, 1]);
  assert.equal(applySetting(s, 'hairColor', 'red'), null);
  assert.equal(applySetting(s, 'nope', 1), null);
});

test('hexToLinear decodes sRGB', () => {
  assert.deepEqual(hexToLinear('#000000'), [0, 0, 0]);
  const g = hexToLinear('#808080');
  assert.ok(Math.abs(g[0] - 0.2158605) < 1e-6);
  assert.equal(hexToLinear('#12345'), null);
});

test('lightDirection is a unit vector at the given azimuth and elevation', () => {
  const d = lightDirection([0, 0, 0], 90, 30);
  assert.ok(Math.abs(Math.hypot(...d) - 1) < 1e-12);
  assert.ok(Math.abs(d[1] - 0.5) < 1e-12 && Math.abs(d[2]) < 1e-12 && d[0] > 0.8);
});
