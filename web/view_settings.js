// Viewer-side settings (not sent to the server): defaults and the specs the View panel shows.

// Each spec: name, label, kind ('float' | 'int' | 'bool' | 'color'), range, step, help, and
// whether changing it needs a new render-strand layout ('layout'), new worker buffers
// ('smoothing'), another stream source ('source': strands or the hair mesh) or new render
// strands of the hair mesh ('meshLayout'); the rest are shader uniforms read every frame.
export const VIEW_SPECS = [
  { name: 'perGuide', label: 'strands per guide', kind: 'int', min: 1, max: 32, step: 1, def: 4, rebuild: 'layout', help: 'Render strands drawn per simulated guide (single- and multi-strand interpolation).' },
  { name: 'segs', label: 'segments per span', kind: 'int', min: 1, max: 8, step: 1, def: 2, rebuild: 'smoothing', help: 'Catmull-Rom points per guide segment.' },
  { name: 'multi', label: 'multi-strand blend', kind: 'float', min: 0, max: 1, step: 0.01, def: 0.6, help: 'How far render strands blend towards neighbouring guides (0: single-strand only).' },
  { name: 'spread', label: 'root spread', kind: 'float', min: 0, max: 3, step: 0.01, def: 1, help: 'Single-strand offset at the root, in units of the guide spacing.' },
  { name: 'tipSpread', label: 'tip spread', kind: 'float', min: 0.2, max: 6, step: 0.05, def: 2, help: 'Offset at the tip as a multiple of the root offset.' },
  { name: 'widthPx', label: 'strand width', kind: 'float', min: 0.5, max: 6, step: 0.1, def: 1.6, help: 'Ribbon width at the root, pixels.' },
  { name: 'tipWidth', label: 'tip taper', kind: 'float', min: 0.05, max: 1, step: 0.05, def: 0.3, help: 'Width at the tip as a fraction of the root width.' },
  { name: 'hairColor', label: 'hair colour', kind: 'color', def: '#8a5a32', help: 'Base hair colour.' },
  { name: 'spec1', label: 'primary highlight', kind: 'float', min: 0, max: 2, step: 0.01, def: 0.35, help: 'Kajiya-Kay lobe shifted towards the root (light coloured).' },
  { name: 'spec2', label: 'secondary highlight', kind: 'float', min: 0, max: 2, step: 0.01, def: 0.3, help: 'Kajiya-Kay lobe shifted towards the tip (hair coloured).' },
  { name: 'shift1', label: 'primary shift', kind: 'float', min: -0.5, max: 0.5, step: 0.01, def: -0.08, help: 'Tangent shift of the primary lobe.' },
  { name: 'shift2', label: 'secondary shift', kind: 'float', min: -0.5, max: 0.5, step: 0.01, def: 0.12, help: 'Tangent shift of the secondary lobe.' },
  { name: 'exp1', label: 'primary sharpness', kind: 'float', min: 1, max: 400, step: 1, def: 90, help: 'Specular exponent of the primary lobe.' },
  { name: 'exp2', label: 'secondary sharpness', kind: 'float', min: 1, max: 400, step: 1, def: 24, help: 'Specular exponent of the secondary lobe.' },
  { name: 'ambient', label: 'ambient', kind: 'float', min: 0, max: 1, step: 0.01, def: 0.22, help: 'Light that reaches hair in full shadow.' },
  { name: 'rootAO', label: 'root darkening', kind: 'float', min: 0, max: 1, step: 0.01, def: 0.45, help: 'Brightness at the root (occlusion by the hair above it).' },
  { name: 'shadows', label: 'self-shadowing', kind: 'bool', def: true, help: 'Opacity shadow map of the hair and head from the light.' },
  { name: 'absorb', label: 'shadow density', kind: 'float', min: 0, max: 1000, step: 5, def: 160, help: 'Light absorbed per metre of hair along the light, 1/m.' },
  { name: 'lightAzimuth', label: 'light azimuth', kind: 'float', min: -180, max: 180, step: 1, def: 35, help: 'Light direction around the vertical axis, degrees.' },
  { name: 'lightElevation', label: 'light elevation', kind: 'float', min: -89, max: 89, step: 1, def: 40, help: 'Light height above the horizon, degrees.' },
  { name: 'hairmesh', label: 'grow from hair mesh', kind: 'bool', def: false, rebuild: 'source', help: 'Stream the simulated hair mesh instead of the strands and grow the render strands from it on the GPU (needs the hairmesh solver).' },
  { name: 'perFace', label: 'strands per mesh face', kind: 'int', min: 1, max: 2000, step: 1, def: 300, rebuild: 'meshLayout', help: 'Render strands grown in each hair mesh face.' },
  { name: 'meshOffset', label: 'mesh strand offset', kind: 'float', min: 0, max: 0.02, step: 0.0005, def: 0.003, help: 'Random offset of each grown strand from its traced path at the root (m); the tip spread scales it at the tip.' },
  { name: 'curl', label: 'curl radius', kind: 'float', min: 0, max: 0.02, step: 0.0005, def: 0, help: 'Radius of the helix each grown strand winds around its traced path (m).' },
  { name: 'curlTurns', label: 'curl turns', kind: 'float', min: 0, max: 20, step: 0.5, def: 4, help: 'Turns of the curl from root to tip.' },
  { name: 'frizz', label: 'frizz', kind: 'float', min: 0, max: 0.02, step: 0.0005, def: 0.003, help: 'Irregular waviness of grown strands, growing towards the tip (m at the tip).' },
  { name: 'meshWire', label: 'show hair mesh', kind: 'bool', def: false, help: 'Draw the streamed hair mesh as a wireframe over the hair.' },
  { name: 'colliders', label: 'show head', kind: 'bool', def: true, help: 'Draw the head and colliders.' },
  { name: 'continuous', label: 'redraw every frame', kind: 'bool', def: false, help: 'Draw on every display frame, not only when something changed (to measure the render rate).' },
];

// A settings object holding every spec's default, plus the derived linear colours.
export function defaultSettings() {
  const s = {};
  for (const spec of VIEW_SPECS) s[spec.name] = spec.def;
  s.hairColorLinear = hexToLinear(s.hairColor);
  s.specColor = [1, 0.95, 0.88];
  s.headColor = [0.5, 0.53, 0.6];
  return s;
}

// '#rrggbb' -> linear RGB in [0, 1] (sRGB decoding); null for anything else.
export function hexToLinear(hex) {
  const m = /^#([0-9a-f]{2})([0-9a-f]{2})([0-9a-f]{2})$/i.exec(typeof hex === 'string' ? hex : '');
  if (!m) return null;
  return [m[1], m[2], m[3]].map((h) => {
    const c = parseInt(h, 16) / 255;
    return c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4);
  });
}

// Applies one change (value from a control) to settings; returns the spec's rebuild kind
// ('layout', 'smoothing' or undefined), or null when the name or value is not acceptable.
export function applySetting(settings, name, value) {
  const spec = VIEW_SPECS.find((x) => x.name === name);
  if (!spec) return null;
  if (spec.kind === 'bool') {
    if (typeof value !== 'boolean') return null;
    settings[name] = value;
  } else if (spec.kind === 'color') {
    const lin = hexToLinear(value);
    if (!lin) return null;
    settings[name] = value;
    settings.hairColorLinear = lin;
  } else {
    const v = Number(value);
    if (!Number.isFinite(v)) return null;
    const c = Math.min(spec.max, Math.max(spec.min, v));
    settings[name] = spec.kind === 'int' ? Math.round(c) : c;
  }
  return spec.rebuild;
}

// Unit vector towards the light for azimuth/elevation in degrees (y up).
export function lightDirection(out, azimuthDeg, elevationDeg) {
  const a = (azimuthDeg * Math.PI) / 180, e = (elevationDeg * Math.PI) / 180;
  out[0] = Math.cos(e) * Math.sin(a); out[1] = Math.sin(e); out[2] = Math.cos(e) * Math.cos(a);
  return out;
}
