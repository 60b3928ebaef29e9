// Tests web/panel_model.js: schema -> control specs, value coercion and formatting.
import test from 'node:test';
import assert from 'node:assert/strict';
import { buildControls, coerceValue, describe, formatValue, niceStep } from '../../web/panel_model.js';

const schema = [
  { name: 'gravity', type: 'float', min: 0, max: 50, default: 9.81, unit: 'm/s^2', help: 'Gravity along -y.' },
  { name: 'substeps', type: 'int', min: 1, max: 16, default: 1, unit: '', help: 'Substeps.' },
  { name: 'sph', type: 'bool', default: true, help: 'Hair-hair interaction.' },
  { name: 'sph_radius', type: 'float', min: 0.001, max: 0.05, default: 0.008, unit: 'm', help: '' },
];

test('every valid schema entry becomes a control with its range, unit and help', () => {
  const { controls, problems } = buildControls(schema);
  assert.deepEqual(problems, []);
  assert.deepEqual(controls.map((c) => [c.name, c.kind]), [['gravity', 'float'], ['substeps', 'int'], ['sph', 'bool'], ['sph_radius', 'float']]);
  const g = controls[0];
  assert.equal(g.min, 0); assert.equal(g.max, 50); assert.equal(g.def, 9.81); assert.equal(g.unit, 'm/s^2');
  assert.equal(g.help, 'Gravity along -y.'); assert.equal(g.label, 'gravity'); assert.equal(g.step, 0.05);
  assert.equal(controls[1].step, 1);
  assert.equal(controls[2].def, true);
  assert.equal(controls[3].label, 'sph radius');
  assert.equal(controls[3].step, 0.00005);
  assert.equal(controls[3].decimals, 5);
});

test('bad entries are reported and left out, the rest still build', () => {
  const { controls, problems } = buildControls([
    null, { type: 'float' }, { name: 'x', type: 'string' }, { name: 'y', type: 'float', min: 2, max: 1 },
    { name: 'z', type: 'float', min: 'a', max: 1 }, schema[0], schema[0], { name: 'w', type: 'int', min: 0, max: 9, default: 99 },
  ]);
  assert.equal(problems.length, 6);
  assert.deepEqual(controls.map((c) => c.name), ['gravity', 'w']);
  assert.equal(controls[1].def, 9, 'default clamped into range');
  assert.deepEqual(buildControls('nope').controls, []);
});

test('niceStep picks 1/2/5 steps', () => {
  assert.equal(niceStep(0, 1), 0.001);
  assert.equal(niceStep(0, 200), 0.2);
  assert.equal(niceStep(-50, 50), 0.1);
  assert.equal(niceStep(0, 0.5), 0.0005);
  assert.equal(niceStep(1, 1), 1);
});

test('coerceValue clamps, rounds ints and rejects non-numbers', () => {
  const { controls: [g, s, b] } = buildControls(schema);
  assert.equal(coerceValue(g, '12.5'), 12.5);
  assert.equal(coerceValue(g, 99), 50);
  assert.equal(coerceValue(g, -1), 0);
  assert.equal(coerceValue(g, 'abc'), null);
  assert.equal(coerceValue(g, ''), null);
  assert.equal(coerceValue(g, NaN), null);
  assert.equal(coerceValue(g, Infinity), null);
  assert.equal(coerceValue(s, '3.6'), 4);
  assert.equal(coerceValue(b, true), true);
  assert.equal(coerceValue(b, 'false'), false);
  assert.equal(coerceValue(b, 'maybe'), null);
});

test('formatValue and describe show units, range and default', () => {
  const { controls: [g, s, b, r] } = buildControls(schema);
  assert.equal(formatValue(g, 9.81), '9.81 m/s^2');
  assert.equal(formatValue(s, 3), '3');
  assert.equal(formatValue(b, false), 'off');
  assert.equal(formatValue(r, 0.008), '0.00800 m');
  assert.equal(formatValue(g, undefined), '—');
  assert.match(describe(g), /Gravity along -y\. Range 0–50 m\/s\^2, default 9\.81 m\/s\^2\./);
  assert.match(describe(b), /default on/);
});
