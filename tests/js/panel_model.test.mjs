// Tests web/panel_model.js: schema -> control specs, value coercion and formatting.
import test from 'node:test';
import assert from 'node:assert/strict';
import {
  LOG_DECADES, LOG_STEPS, buildControls, coerceValue, describe, formatNumber, formatValue, fromSlider, groomChoices, niceStep, sliderPositions,
  toSlider, visibleFor,
} from '../../web/panel_model.js';

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

// the server's stiffness entries (server/sim/sim_params.c) and log entries on other ranges
const stiff = { name: 'local_stiffness', type: 'float', min: 0, max: 1e8, default: 1e6, unit: '1/s^2', help: 'Bending.', scale: 'log' };
const logControl = (min, max) => buildControls([{ ...stiff, min, max, default: max }]).controls[0];

test('a "log" scale hint is kept; absent, unknown or unfit hints are linear', () => {
  const { controls, problems } = buildControls([
    stiff, schema[0],
    { ...stiff, name: 'a', scale: 'LOG' }, { ...stiff, name: 'b', scale: 7 }, { ...stiff, name: 'c', scale: 'linear' },
    { ...stiff, name: 'd', min: -1 }, { ...stiff, name: 'e', type: 'int' }, { ...stiff, name: 'f', min: 1, max: 5, default: 2 },
    { ...stiff, name: 'g', min: 0, max: 0, default: 0 }, { name: 'h', type: 'bool', default: true, scale: 'log' },
  ]);
  assert.deepEqual(problems, []);
  assert.deepEqual(controls.map((c) => c.scale), ['log', 'linear', 'linear', 'linear', 'linear', 'linear', 'linear', 'linear', 'linear', 'linear']);
});

test('log slider with min 0: an explicit 0, then LOG_DECADES decades up to max', () => {
  const c = logControl(0, 1e8);
  const n = sliderPositions(c);
  assert.equal(n, 1 + LOG_DECADES * LOG_STEPS);
  assert.equal(fromSlider(c, 0), 0);
  assert.equal(fromSlider(c, 1), 1e8 / 10 ** LOG_DECADES);
  assert.equal(fromSlider(c, n), 1e8);
  // powers of ten of a power-of-ten max land on positions: 1,000 can be picked
  assert.equal(toSlider(c, 1000), 1 + LOG_STEPS);
  assert.equal(fromSlider(c, 1 + LOG_STEPS), 1000);
  assert.equal(fromSlider(c, n - LOG_STEPS), 1e7);
  // the middle of the slider is in the middle decade (1e5 for [0, 1e8] over six decades)
  const mid = fromSlider(c, Math.round(n / 2));
  assert.ok(mid >= 3e4 && mid <= 3e5, `mid ${mid}`);
  // slider values are rounded to three significant digits
  assert.equal(fromSlider(c, 1 + LOG_STEPS + 20), 1580); // 10^3.2 = 1584.9
});

test('log slider: position -> value -> position round trips, values increase', () => {
  for (const [min, max] of [[0, 1e8], [0, 1e6], [0, 0.3], [0.001, 0.05], [0.1, 10], [1e-3, 7.3e4]]) {
    const c = logControl(min, max);
    const n = sliderPositions(c);
    let last = -1;
    for (let p = 0; p <= n; p++) {
      const v = fromSlider(c, p);
      assert.ok(v >= min && v <= max && v > last, `[${min}, ${max}] position ${p}: ${v}`);
      assert.equal(toSlider(c, v), p, `[${min}, ${max}] position ${p} value ${v}`);
      last = v;
    }
    assert.equal(fromSlider(c, 0), min);
    assert.equal(fromSlider(c, n), max);
  }
});

test('log slider clamps positions and values, and places values between positions', () => {
  const c = logControl(0, 1e6);
  const n = sliderPositions(c);
  assert.equal(fromSlider(c, -5), 0);
  assert.equal(fromSlider(c, n + 40), 1e6);
  assert.equal(fromSlider(c, 'x'), 0);
  assert.equal(toSlider(c, -3), 0);
  assert.equal(toSlider(c, 0), 0);
  assert.equal(toSlider(c, 1e-9), 1, 'a value below the first decade sits just right of 0');
  assert.equal(toSlider(c, 5e9), n);
  assert.equal(toSlider(c, NaN), 0);
  assert.equal(toSlider(c, 1e5), n - LOG_STEPS);
  assert.equal(toSlider(c, 1.01e5), n - LOG_STEPS, 'nearest position');
  const m = logControl(0.1, 10);
  assert.equal(toSlider(m, 0.05), 0);
  assert.equal(fromSlider(m, 0), 0.1);
  // the number box takes any value in range, not only slider values
  assert.equal(coerceValue(c, '1234.5'), 1234.5);
  assert.equal(coerceValue(c, '2e7'), 1e6);
});

test('large values are shown as powers of ten, with the unit', () => {
  const c = logControl(0, 1e8);
  assert.equal(formatValue(c, 1e5), '1e5 1/s^2');
  assert.equal(formatValue(c, 2.5e7), '2.5e7 1/s^2');
  assert.equal(formatValue(c, 1990), '1990 1/s^2');
  assert.equal(formatValue(c, 0), '0 1/s^2');
  assert.equal(formatNumber(123456789), '1.23457e8');
  assert.equal(formatNumber(99999), '99999');
  assert.equal(formatNumber(-3e6), '-3e6');
  assert.equal(describe(c), 'Bending. Range 0–1e8 1/s^2, default 1e8 1/s^2. Logarithmic slider.');
});

test('an enum becomes a choice control; solver-specific parameters show only for their solver', () => {
  const { controls, problems } = buildControls([
    { name: 'solver', type: 'enum', min: 0, max: 2, choices: ['dftl', 'hairmesh', 'pbd'], default: 'dftl', unit: '', help: 'The solver.' },
    { name: 'pbd_iterations', type: 'int', min: 1, max: 32, default: 4, unit: '', help: 'Iterations.', solvers: ['pbd'] },
    { name: 'gravity', type: 'float', min: 0, max: 50, default: 9.81, unit: 'm/s^2', help: 'Gravity.' },
    { name: 'bad1', type: 'enum', min: 0, max: 0, default: 'a', unit: '', help: '' },
    { name: 'bad2', type: 'enum', min: 0, max: 1, choices: ['a', 'a'], default: 'a', unit: '', help: '' },
    { name: 'bad3', type: 'float', min: 0, max: 1, default: 0, unit: '', help: '', solvers: 'pbd' },
    { name: 'odd', type: 'enum', min: 0, max: 1, choices: ['x', 'y'], default: 'z', unit: '', help: '' },
  ]);
  assert.equal(problems.length, 3);
  const [solver, it, g, odd] = controls;
  assert.equal(solver.kind, 'enum');
  assert.deepEqual(solver.choices, ['dftl', 'hairmesh', 'pbd']);
  assert.equal(solver.def, 'dftl');
  assert.equal(odd.def, 'x', 'an unknown default falls back to the first choice');
  assert.equal(coerceValue(solver, 'pbd'), 'pbd');
  assert.equal(coerceValue(solver, 'PBD'), null);
  assert.equal(coerceValue(solver, 2), null);
  assert.equal(formatValue(solver, 'pbd'), 'pbd');
  assert.match(describe(solver), /Choices: dftl, hairmesh, pbd; default dftl\./);
  assert.ok(visibleFor(it, 'pbd'));
  assert.ok(!visibleFor(it, 'dftl'));
  assert.ok(visibleFor(g, 'dftl') && visibleFor(g, 'pbd'));
  assert.ok(visibleFor(it, undefined), 'with no solver known every control shows');
});

test('groom choices: procedural and hair-mesh styles, then files; the current groom selected', () => {
  const grooms = { styles: ['straight', 'wavy', 'hairmesh:straight', 7], files: ['ratboy/Ratboy_mohawk.tfx'], colliders: [] };
  const { options, selected } = groomChoices(grooms, 'hairmesh:straight');
  assert.deepEqual(options, [
    { value: 'style:straight', text: 'procedural straight' },
    { value: 'style:wavy', text: 'procedural wavy' },
    { value: 'style:hairmesh:straight', text: 'hair mesh straight' },
    { value: 'file:ratboy/Ratboy_mohawk.tfx', text: 'ratboy/Ratboy_mohawk.tfx' },
  ]);
  assert.equal(selected, 'style:hairmesh:straight');
  assert.equal(groomChoices(grooms, 'procedural:wavy').selected, 'style:wavy');
  assert.equal(groomChoices(grooms, 'file:ratboy/Ratboy_mohawk.tfx').selected, 'file:ratboy/Ratboy_mohawk.tfx');
  assert.equal(groomChoices(grooms, 'hairmesh:curly').selected, '', 'a style the server does not list selects nothing');
  assert.deepEqual(groomChoices(null, undefined), { options: [], selected: '' });
});
