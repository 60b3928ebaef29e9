// Parameter panel model: the server's parameter schema turned into validated control specs.

// A "nice" slider step (1, 2 or 5 times a power of ten) giving about `divisions` steps.
export function niceStep(min, max, divisions = 1000) {
  const span = max - min;
  if (!(span > 0) || !Number.isFinite(span)) return 1;
  const raw = span / divisions;
  const e = Math.floor(Math.log10(raw));
  const m = raw / Math.pow(10, e);
  const nice = m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10;
  // divide by a power of ten for small steps so that 5e-5 comes out exact
  return e < 0 ? nice / Math.pow(10, -e) : nice * Math.pow(10, e);
}

// Log sliders (the schema's "scale": "log", proto/PROTOCOL.md "Parameter scale"): integer
// positions 0..N, LOG_STEPS per decade, anchored at max: v(p) = max * 10^((p - N) / LOG_STEPS),
// rounded to LOG_DIGITS significant digits. min = 0: position 0 is exactly 0 and 1..N span the
// LOG_DECADES below max (N = 1 + LOG_DECADES * LOG_STEPS). min > 0: N = round(LOG_STEPS *
// log10(max / min)) and position 0 is exactly min. Powers of ten below a power-of-ten max land
// on positions.
export const LOG_STEPS = 100;
export const LOG_DECADES = 6;
const LOG_DIGITS = 3;

// The scale a schema entry asks for: 'log' only for a float with min >= 0, max > 0 and (for
// min > 0) max >= 10 min; anything else (absent, unknown strings, log on an unfit range) is
// 'linear'. Pure.
function scaleOf(e, kind, min, max) {
  return e.scale === 'log' && kind === 'float' && min >= 0 && max > 0 && (min === 0 || max >= 10 * min) ? 'log' : 'linear';
}

// The top slider position N of log control c.
export function sliderPositions(c) {
  return c.min > 0 ? Math.round(LOG_STEPS * Math.log10(c.max / c.min)) : 1 + LOG_DECADES * LOG_STEPS;
}

// The value at slider position p (rounded and clamped to 0..N) of log control c, in [min, max]. Pure.
export function fromSlider(c, p) {
  const n = sliderPositions(c);
  const q = Math.min(n, Math.max(0, Math.round(Number(p) || 0)));
  if (q === n) return c.max;
  if (q === 0) return c.min;
  const v = Number((c.max * Math.pow(10, (q - n) / LOG_STEPS)).toPrecision(LOG_DIGITS));
  return Math.min(c.max, Math.max(c.min, v));
}

// The slider position nearest value v of log control c (the inverse of fromSlider on the values
// it returns); v <= min is position 0, and with min = 0 any 0 < v below the slider's first
// decade is position 1. Pure.
export function toSlider(c, v) {
  const x = Number(v);
  if (!Number.isFinite(x) || x <= c.min) return 0;
  const n = sliderPositions(c);
  return Math.min(n, Math.max(1, n + Math.round(LOG_STEPS * Math.log10(x / c.max))));
}

// A number for people: up to `digits` significant digits, powers of ten from 1e5 up written
// as 1e5, 2.5e7. Pure.
export function formatNumber(v, digits = 6) {
  if (typeof v !== 'number' || !Number.isFinite(v)) return '—';
  if (Math.abs(v) < 1e5) return String(Number(v.toPrecision(digits)));
  const [m, e] = v.toExponential(digits - 1).split('e');
  return `${Number(m)}e${Number(e)}`;
}

function decimalsOf(step) {
  if (!(step > 0) || step >= 1) return 0;
  return Math.min(8, Math.ceil(-Math.log10(step) - 1e-9));
}

// Builds control specs from a schema array (hello.params.schema). Each valid entry becomes
// { name, label, kind: 'float'|'int'|'bool'|'enum', scale: 'linear'|'log', min, max, step,
// decimals, unit, help, def, choices, solvers } (step and decimals are for linear sliders and
// number boxes; choices, the names an enum takes, null for the others; solvers, the solvers the
// parameter applies to, null for every one: see visibleFor); invalid entries are left out and
// described in problems (strings). Pure.
export function buildControls(schema) {
  const controls = [], problems = [];
  if (!Array.isArray(schema)) return { controls, problems: ['params.schema is not an array'] };
  const seen = new Set();
  schema.forEach((e, i) => {
    if (!e || typeof e !== 'object') { problems.push(`schema[${i}] is not an object`); return; }
    const name = e.name;
    if (typeof name !== 'string' || !name) { problems.push(`schema[${i}] has no name`); return; }
    if (seen.has(name)) { problems.push(`schema[${i}]: duplicate parameter ${name}`); return; }
    const kind = e.type;
    if (kind !== 'float' && kind !== 'int' && kind !== 'bool' && kind !== 'enum') {
      problems.push(`parameter ${name}: unknown type ${JSON.stringify(kind)}`);
      return;
    }
    const c = {
      name,
      label: name.replace(/_/g, ' '),
      kind,
      scale: 'linear',
      unit: typeof e.unit === 'string' ? e.unit : '',
      help: typeof e.help === 'string' ? e.help : '',
      min: 0, max: 1, step: 1, decimals: 0, def: 0,
      choices: null,
      solvers: null,
    };
    if (e.solvers !== undefined) {
      if (!Array.isArray(e.solvers) || !e.solvers.length || !e.solvers.every((n) => typeof n === 'string' && n)) {
        problems.push(`parameter ${name}: solvers is not a list of names`);
        return;
      }
      c.solvers = e.solvers.slice();
    }
    if (kind === 'bool') {
      c.def = e.default === true || e.default === 1;
    } else if (kind === 'enum') {
      const ch = e.choices;
      if (!Array.isArray(ch) || !ch.length || !ch.every((n) => typeof n === 'string' && n) || new Set(ch).size !== ch.length) {
        problems.push(`parameter ${name}: enum without a list of distinct choice names`);
        return;
      }
      c.choices = ch.slice();
      c.max = ch.length - 1;
      c.def = ch.includes(e.default) ? e.default : ch[0];
    } else {
      const min = Number(e.min), max = Number(e.max);
      if (!Number.isFinite(min) || !Number.isFinite(max) || !(max >= min)) {
        problems.push(`parameter ${name}: bad range [${e.min}, ${e.max}]`);
        return;
      }
      c.min = min; c.max = max;
      c.scale = scaleOf(e, kind, min, max);
      c.step = kind === 'int' ? 1 : niceStep(min, max);
      c.decimals = kind === 'int' ? 0 : decimalsOf(c.step);
      const d = Number(e.default);
      c.def = Number.isFinite(d) ? Math.min(max, Math.max(min, d)) : min;
    }
    seen.add(name);
    controls.push(c);
  });
  return { controls, problems };
}

// Turns a raw input (number, string from an <input>, boolean) into a valid value for control c,
// clamped to its range (ints rounded), or null when it is not a finite number / boolean (for an
// enum: the choice's name, or null when raw names none of them). Pure.
export function coerceValue(c, raw) {
  if (c.kind === 'enum') return typeof raw === 'string' && c.choices.includes(raw) ? raw : null;
  if (c.kind === 'bool') {
    if (raw === true || raw === 'true' || raw === 1 || raw === '1') return true;
    if (raw === false || raw === 'false' || raw === 0 || raw === '0') return false;
    return null;
  }
  if (typeof raw === 'string' && raw.trim() === '') return null;
  const v = typeof raw === 'number' ? raw : Number(raw);
  if (!Number.isFinite(v)) return null;
  const clamped = Math.min(c.max, Math.max(c.min, v));
  return c.kind === 'int' ? Math.round(clamped) : clamped;
}

// Text shown beside a control: the value with the step's decimals (log controls: three
// significant digits, 1e5 and up as powers of ten) and the unit.
export function formatValue(c, v) {
  if (c.kind === 'enum') return typeof v === 'string' ? v : '—';
  if (c.kind === 'bool') return v ? 'on' : 'off';
  if (typeof v !== 'number' || !Number.isFinite(v)) return '—';
  const s = c.scale === 'log' ? formatNumber(v, LOG_DIGITS) : v.toFixed(c.kind === 'int' ? 0 : c.decimals);
  return c.unit ? `${s} ${c.unit}` : s;
}

// Tooltip for a control: help text, range and default.
export function describe(c) {
  if (c.kind === 'enum') return `${c.help}${c.help ? ' ' : ''}Choices: ${c.choices.join(', ')}; default ${c.def}.`;
  if (c.kind === 'bool') return `${c.help}${c.help ? ' ' : ''}(default ${c.def ? 'on' : 'off'})`;
  const u = c.unit ? ` ${c.unit}` : '';
  const f = (v) => formatNumber(v);
  const scale = c.scale === 'log' ? ' Logarithmic slider.' : '';
  return `${c.help}${c.help ? ' ' : ''}Range ${f(c.min)}–${f(c.max)}${u}, default ${f(c.def)}${u}.${scale}`;
}

// Whether control c applies to the solver named solver (the value of the solver parameter): a
// control without a solvers list applies to every solver; with no solver known, all show. Pure.
export function visibleFor(c, solver) {
  return !c.solvers || typeof solver !== 'string' || c.solvers.includes(solver);
}

// The groom choices of the hello's grooms (styles: procedural names and "hairmesh:<style>",
// files) as select options {value, text}, and the option of the groom whose source is given
// ("procedural:<style>", "hairmesh:<style>", "file:<name>"; '' when none matches). Pure.
export function groomChoices(grooms, source) {
  const styles = grooms && Array.isArray(grooms.styles) ? grooms.styles.filter((s) => typeof s === 'string') : [];
  const files = grooms && Array.isArray(grooms.files) ? grooms.files.filter((f) => typeof f === 'string') : [];
  const options = [
    ...styles.map((s) => ({ value: `style:${s}`, text: s.startsWith('hairmesh:') ? `hair mesh ${s.slice(9)}` : `procedural ${s}` })),
    ...files.map((f) => ({ value: `file:${f}`, text: f })),
  ];
  const src = typeof source === 'string' ? source : '';
  const want = src.startsWith('procedural:') ? `style:${src.slice(11)}` : src.startsWith('hairmesh:') ? `style:${src}` : src;
  return { options, selected: options.some((o) => o.value === want) ? want : '' };
}
