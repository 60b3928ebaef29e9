// The control panel: server parameters (built from the hello schema), motion and presets,
// groom choice and the viewer's own settings; it follows changes made by other clients.
import { buildControls, coerceValue, describe, formatNumber, formatValue, fromSlider, groomChoices, sliderPositions, toSlider, visibleFor } from './panel_model.js';

const SEND_INTERVAL_MS = 60;

function el(tag, attrs, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === 'class') e.className = v;
    else if (k === 'text') e.textContent = v;
    else e.setAttribute(k, v);
  }
  for (const c of children) if (c) e.append(c);
  return e;
}

function section(title, open = true) {
  const d = el('details', { class: 'section' }, el('summary', { text: title }));
  d.open = open;
  return d;
}

// A slider + number box (a checkbox, or a drop-down for an enum) bound to control spec c. onChange(value, final) is
// called with coerced values; set(v) shows a value without calling onChange.
function controlRow(c, value, onChange, dataAttr) {
  const row = el('div', { class: 'row', title: describe(c) });
  row.append(el('label', { text: c.label }));
  let set;
  if (c.kind === 'enum') {
    const select = el('select', { [dataAttr]: c.name });
    for (const name of c.choices) select.append(el('option', { value: name, text: name }));
    select.value = value;
    select.addEventListener('change', () => onChange(select.value, true));
    row.append(select);
    set = (v) => { select.value = v; };
    return { row, set, dragging: () => false };
  }
  if (c.kind === 'bool') {
    const box = el('input', { type: 'checkbox', [dataAttr]: c.name });
    box.checked = !!value;
    box.addEventListener('change', () => onChange(box.checked, true));
    const out = el('span', { class: 'value', text: formatValue(c, !!value) });
    box.addEventListener('change', () => { out.textContent = formatValue(c, box.checked); });
    row.append(box, out);
    set = (v) => { box.checked = !!v; out.textContent = formatValue(c, !!v); };
    return { row, set, dragging: () => false };
  }
  // a log control's slider runs over positions (panel_model.js fromSlider/toSlider); its
  // number box takes any value in range
  const log = c.scale === 'log';
  const range = log
    ? el('input', { type: 'range', min: 0, max: sliderPositions(c), step: 1, [dataAttr]: c.name, 'data-scale': 'log' })
    : el('input', { type: 'range', min: c.min, max: c.max, step: c.step, [dataAttr]: c.name });
  const num = el('input', { type: 'number', min: c.min, max: c.max, step: log ? 'any' : c.step, class: 'num' });
  const fromRange = () => coerceValue(c, log ? fromSlider(c, range.value) : range.value);
  const unit = el('span', { class: 'unit', text: c.unit || '' });
  let dragging = false;
  range.addEventListener('pointerdown', () => { dragging = true; });
  const release = () => { dragging = false; };
  range.addEventListener('pointerup', release);
  range.addEventListener('pointercancel', release);
  // the number box shows the exact value (a server value may lie between slider steps)
  const text = (v) => (c.kind === 'int' ? String(v) : log ? formatNumber(Number(v)) : String(Number(Number(v).toPrecision(6))));
  const show = (v) => {
    range.value = String(log ? toSlider(c, v) : v);
    num.value = text(v);
  };
  range.addEventListener('input', () => {
    const v = fromRange();
    if (v === null) return;
    num.value = text(v);
    onChange(v, false);
  });
  range.addEventListener('change', () => {
    dragging = false;
    const v = fromRange();
    if (v !== null) onChange(v, true);
  });
  num.addEventListener('change', () => {
    const v = coerceValue(c, num.value);
    if (v === null) { num.classList.add('bad'); return; }
    num.classList.remove('bad');
    show(v);
    onChange(v, true);
  });
  show(value);
  row.append(range, num, unit);
  set = show;
  return { row, set, dragging: () => dragging };
}

export class Panel {
  // root: the panel element. actions: { setParams(values), animate(preset, speed), reset(),
  // pause(), resume(), step(), setGroom(spec), setView(name, value) }.
  constructor(root, actions) {
    this.root = root;
    this.actions = actions;
    this.params = new Map(); // name -> { c, set, dragging, value, timer, pending }
    this.paramBox = el('div');
    this.motionBox = el('div');
    this.groomBox = el('div');
    this.viewBox = el('div');
    this.status = el('div', { class: 'status', role: 'status' });
    const sim = section('Simulation');
    sim.append(this.paramBox);
    const motion = section('Motion');
    motion.append(this.motionBox);
    const groom = section('Groom', false);
    groom.append(this.groomBox);
    const view = section('View', false);
    view.append(this.viewBox);
    root.replaceChildren(sim, motion, groom, view, this.status);
    this.statusTimer = null;
    this.preset = 'none';
    this.speed = 1;
    this.paused = false;
  }

  // Builds the parameter rows from hello.params ({ schema, values }).
  buildParams(params) {
    const { controls, problems } = buildControls(params && params.schema);
    this.params.clear();
    this.paramBox.replaceChildren();
    for (const c of controls) {
      const v = params.values && params.values[c.name] !== undefined ? params.values[c.name] : c.def;
      const entry = { c, value: v, timer: null, pending: null, set: null, dragging: null };
      const ui = controlRow(c, v, (nv, final) => this._local(entry, nv, final), 'data-param');
      entry.set = ui.set;
      entry.dragging = ui.dragging;
      entry.row = ui.row;
      this.params.set(c.name, entry);
      this.paramBox.append(ui.row);
    }
    this._showSolverParams();
    if (problems.length) this.showStatus(`schema problems: ${problems.join('; ')}`, true);
  }

  _local(entry, v, final) {
    entry.pending = v;
    if (final) {
      clearTimeout(entry.timer);
      entry.timer = null;
      this._flush(entry);
    } else if (!entry.timer) {
      this._flush(entry);
      entry.timer = setTimeout(() => { entry.timer = null; if (entry.pending !== null) this._flush(entry); }, SEND_INTERVAL_MS);
    }
  }

  _flush(entry) {
    const v = entry.pending;
    entry.pending = null;
    if (v === null || v === entry.sent) return;
    entry.sent = v;
    this.actions.setParams({ [entry.c.name]: v });
  }

  // Shows values announced by the server (a params message); a slider being dragged keeps the
  // user's value.
  updateParams(values) {
    if (!values || typeof values !== 'object') return;
    for (const [name, raw] of Object.entries(values)) {
      const entry = this.params.get(name);
      if (!entry) continue;
      const v = coerceValue(entry.c, raw);
      if (v === null) continue;
      entry.value = v;
      entry.sent = undefined;
      if (!entry.dragging()) entry.set(v);
    }
    this._showSolverParams();
  }

  // Shows only the parameters of the active solver (the solver parameter's announced value).
  _showSolverParams() {
    const solver = this.params.get('solver');
    for (const entry of this.params.values()) entry.row.hidden = !visibleFor(entry.c, solver && solver.value);
  }

  // Puts a rejected parameter back to the last value the server announced.
  revertParam(name) {
    const entry = this.params.get(name);
    if (!entry) return;
    entry.sent = undefined;
    entry.set(entry.value);
  }

  // Preset buttons, speed slider, reset / pause / step.
  buildMotion(presets, animation, limits) {
    this.motionBox.replaceChildren();
    const names = Array.isArray(presets) ? presets.filter((p) => typeof p === 'string') : [];
    const buttons = el('div', { class: 'buttons' });
    this.presetButtons = new Map();
    for (const p of names) {
      const b = el('button', { type: 'button', 'data-preset': p, text: p === 'none' ? 'stop' : p });
      b.addEventListener('click', () => this.actions.animate(p, this.speed));
      this.presetButtons.set(p, b);
      buttons.append(b);
    }
    const maxSpeed = limits && Number.isFinite(limits.max_speed) ? limits.max_speed : 5;
    const speedSpec = { name: 'speed', label: 'speed', kind: 'float', min: 0.1, max: Math.min(maxSpeed, 10), step: 0.1, decimals: 1, unit: 'x', help: 'Preset animation speed factor.', def: 1 };
    const speed = controlRow(speedSpec, this.speed, (v, final) => {
      this.speed = v;
      if (final && this.preset !== 'none') this.actions.animate(this.preset, v);
    }, 'data-motion');
    this.speedControl = speed;
    const ctl = el('div', { class: 'buttons' });
    const reset = el('button', { type: 'button', 'data-action': 'reset', text: 'reset' });
    reset.addEventListener('click', () => this.actions.reset());
    this.pauseButton = el('button', { type: 'button', 'data-action': 'pause', text: 'pause' });
    this.pauseButton.addEventListener('click', () => (this.paused ? this.actions.resume() : this.actions.pause()));
    this.stepButton = el('button', { type: 'button', 'data-action': 'step', text: 'step' });
    this.stepButton.addEventListener('click', () => this.actions.step());
    ctl.append(reset, this.pauseButton, this.stepButton);
    const hint = el('div', { class: 'hint', text: 'Drag the head to move it; shift-drag or right-drag turns it. Drag elsewhere to orbit, wheel or pinch to zoom.' });
    this.motionBox.append(buttons, speed.row, ctl, hint);
    this.updateState({ paused: this.paused, animation });
  }

  // Reflects a state message (paused, animation).
  updateState(state) {
    if (!state) return;
    if (typeof state.paused === 'boolean') this.paused = state.paused;
    if (state.animation && typeof state.animation.preset === 'string') {
      this.preset = state.animation.preset;
      if (Number.isFinite(state.animation.speed)) {
        this.speed = state.animation.speed;
        if (this.speedControl) this.speedControl.set(this.speed);
      }
    }
    if (this.pauseButton) {
      this.pauseButton.textContent = this.paused ? 'resume' : 'pause';
      this.stepButton.disabled = !this.paused;
    }
    if (this.presetButtons) for (const [p, b] of this.presetButtons) b.classList.toggle('active', p === this.preset);
  }

  // Groom choice: procedural styles and hair-mesh styles (with strand and vertex counts) or the
  // server's files.
  buildGrooms(grooms, groom, limits) {
    this.groomBox.replaceChildren();
    const select = el('select', { 'data-groom': 'source' });
    const choices = groomChoices(grooms, groom && groom.source);
    for (const o of choices.options) select.append(el('option', o));
    select.value = choices.selected;
    const maxStrands = limits && limits.max_strands > 0 ? limits.max_strands : 65536;
    const maxVerts = limits && limits.max_verts > 0 ? limits.max_verts : 256;
    const strands = el('input', { type: 'number', min: 1, max: maxStrands, step: 1, class: 'num wide', title: 'Guide strands (procedural and hair-mesh styles; a hair mesh rounds up to whole strands per face)' });
    strands.value = groom && groom.strands ? groom.strands : 4096;
    const verts = el('input', { type: 'number', min: 2, max: maxVerts, step: 1, class: 'num', title: 'Vertices per strand (procedural and hair-mesh styles)' });
    verts.value = groom && groom.verts ? groom.verts : 32;
    const apply = el('button', { type: 'button', text: 'load' });
    apply.addEventListener('click', () => {
      const v = select.value;
      if (v.startsWith('file:')) this.actions.setGroom({ file: v.slice(5) });
      else if (v.startsWith('style:')) {
        const s = Math.round(Number(strands.value)), n = Math.round(Number(verts.value));
        if (!(s >= 1 && s <= maxStrands && n >= 2 && n <= maxVerts)) {
          this.showStatus(`strands must be 1–${maxStrands} and vertices 2–${maxVerts}`, true);
          return;
        }
        this.actions.setGroom({ style: v.slice(6), strands: s, verts: n });
      }
    });
    this.groomBox.append(
      el('div', { class: 'row' }, el('label', { text: 'groom' }), select),
      el('div', { class: 'row' }, el('label', { text: 'strands × verts' }), strands, verts, apply),
    );
  }

  // The viewer settings (VIEW_SPECS from view_settings.js).
  buildView(specs, settings) {
    this.viewBox.replaceChildren();
    for (const spec of specs) {
      if (spec.kind === 'color') {
        const input = el('input', { type: 'color', 'data-view': spec.name });
        input.value = settings[spec.name];
        input.addEventListener('input', () => this.actions.setView(spec.name, input.value));
        this.viewBox.append(el('div', { class: 'row', title: spec.help }, el('label', { text: spec.label }), input));
        continue;
      }
      const c = { ...spec, decimals: spec.step < 1 ? Math.ceil(-Math.log10(spec.step) - 1e-9) : 0, unit: '' };
      const ui = controlRow(c, settings[spec.name], (v) => this.actions.setView(spec.name, v), 'data-view');
      ui.row.title = spec.help;
      this.viewBox.append(ui.row);
    }
  }

  // A line under the panel; errors stay until replaced, notes fade after 4 s.
  showStatus(text, isError) {
    this.status.textContent = text;
    this.status.classList.toggle('error', !!isError);
    clearTimeout(this.statusTimer);
    this.statusTimer = setTimeout(() => { this.status.textContent = ''; }, isError ? 10000 : 4000);
  }
}
