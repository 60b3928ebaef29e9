// Render-strand layout: which guides each render strand follows, with what weights and offset
// (single-strand interpolation in a guide's frame plus multi-strand blending of neighbours).

// Bytes per render strand in the instance buffer: uint32 guide ids [g0, g1, g2], float32
// barycentric weights [b1, b2] of g1 and g2 (before the viewer's multi-strand factor), float32
// offset [ox, oy] in metres in g0's (normal, binormal) frame at the root, float32 [length
// fraction, shade].
export const INSTANCE_STRIDE = 36;
export const INSTANCE_FLOATS = 9;

// A small deterministic PRNG (mulberry32); returns a function giving floats in [0, 1).
export function rng(seed) {
  let a = seed >>> 0;
  return function next() {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

// For each of n points (xyz in roots), its two nearest other points and the distance to the
// nearest. Returns { n1: Int32Array, n2: Int32Array, d1: Float32Array, d2: Float32Array }
// (-1 and Infinity where fewer than two other points exist). Uses a uniform grid: O(n).
export function nearestTwo(roots, n) {
  const n1 = new Int32Array(n).fill(-1), n2 = new Int32Array(n).fill(-1);
  const d1 = new Float32Array(n).fill(Infinity), d2 = new Float32Array(n).fill(Infinity);
  if (n < 2) return { n1, n2, d1, d2 };
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < n; i++) {
    for (let c = 0; c < 3; c++) {
      const v = roots[3 * i + c];
      if (v < lo[c]) lo[c] = v;
      if (v > hi[c]) hi[c] = v;
    }
  }
  const ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
  const vol = Math.max(ext[0], 1e-9) * Math.max(ext[1], 1e-9) * Math.max(ext[2], 1e-9);
  // about two points per cell for a surface-like set, and at most ~n cells
  const h = Math.max(Math.cbrt((2 * vol) / n), Math.max(ext[0], ext[1], ext[2]) / 256, 1e-9);
  const dim = ext.map((e) => Math.max(1, Math.min(256, Math.floor(e / h) + 1)));
  const cellOf = (i, c) => Math.min(dim[c] - 1, Math.floor((roots[3 * i + c] - lo[c]) / h));
  const ncell = dim[0] * dim[1] * dim[2];
  const start = new Int32Array(ncell + 1), order = new Int32Array(n), cell = new Int32Array(n);
  for (let i = 0; i < n; i++) {
    cell[i] = (cellOf(i, 2) * dim[1] + cellOf(i, 1)) * dim[0] + cellOf(i, 0);
    start[cell[i] + 1]++;
  }
  for (let c = 0; c < ncell; c++) start[c + 1] += start[c];
  const fill = start.slice(0, ncell);
  for (let i = 0; i < n; i++) order[fill[cell[i]]++] = i;
  const maxRing = Math.max(dim[0], dim[1], dim[2]);
  for (let i = 0; i < n; i++) {
    const cx = cellOf(i, 0), cy = cellOf(i, 1), cz = cellOf(i, 2);
    const x = roots[3 * i], y = roots[3 * i + 1], z = roots[3 * i + 2];
    let b1 = -1, b2 = -1, e1 = Infinity, e2 = Infinity;
    for (let r = 0; r <= maxRing; r++) {
      for (let dz = -r; dz <= r; dz++) {
        const gz = cz + dz;
        if (gz < 0 || gz >= dim[2]) continue;
        for (let dy = -r; dy <= r; dy++) {
          const gy = cy + dy;
          if (gy < 0 || gy >= dim[1]) continue;
          const onShell = Math.abs(dz) === r || Math.abs(dy) === r;
          for (let dx = -r; dx <= r; dx += onShell ? 1 : 2 * r || 1) {
            const gx = cx + dx;
            if (gx < 0 || gx >= dim[0]) continue;
            const c = (gz * dim[1] + gy) * dim[0] + gx;
            for (let k = start[c]; k < start[c + 1]; k++) {
              const j = order[k];
              if (j === i) continue;
              const dd = Math.hypot(roots[3 * j] - x, roots[3 * j + 1] - y, roots[3 * j + 2] - z);
              if (dd < e1 || (dd === e1 && j < b1)) { b2 = b1; e2 = e1; b1 = j; e1 = dd; } else if (dd < e2 || (dd === e2 && j < b2)) { b2 = j; e2 = dd; }
            }
          }
        }
      }
      // every point not yet visited is at least r * h away
      if (b2 >= 0 && e2 <= r * h) break;
    }
    n1[i] = b1; n2[i] = b2; d1[i] = e1; d2[i] = e2;
  }
  return { n1, n2, d1, d2 };
}

function median(values) {
  const finite = Array.from(values).filter(Number.isFinite).sort((a, b) => a - b);
  return finite.length ? finite[finite.length >> 1] : 0;
}

// Builds the instance data for perGuide render strands per guide (nguides roots, xyz in
// guide-local rest coordinates). Render strand 0 of each guide is the guide itself; the others
// get random barycentric weights towards the guide's two nearest neighbours (only those within
// maxBlend times the median guide spacing, so strands never blend across a parting) and a
// random offset in a disc whose radius is the distance to the nearest guide (0.5 * spacing when
// isolated). Deterministic for a seed. Returns { count, data: ArrayBuffer, guideData:
// ArrayBuffer, spacing }: guideData holds render strand 0 of every guide alone (the guides
// themselves, for the shadow pass), spacing is the median nearest-guide distance in metres.
export function buildLayout(roots, nguides, perGuide, { seed = 1, maxBlend = 3, lengthJitter = 0.15 } = {}) {
  const nb = nearestTwo(roots, nguides);
  const spacing = median(nb.d1) || 0.005;
  const limit = maxBlend * spacing;
  const count = nguides * perGuide;
  const data = new ArrayBuffer(count * INSTANCE_STRIDE);
  const u32 = new Uint32Array(data), f32 = new Float32Array(data);
  const rand = rng(seed);
  for (let g = 0; g < nguides; g++) {
    const ok1 = nb.n1[g] >= 0 && nb.d1[g] <= limit, ok2 = nb.n2[g] >= 0 && nb.d2[g] <= limit;
    const g1 = ok1 ? nb.n1[g] : g, g2 = ok2 ? nb.n2[g] : g;
    const radius = Number.isFinite(nb.d1[g]) && nb.d1[g] <= limit ? nb.d1[g] : 0.5 * spacing;
    for (let r = 0; r < perGuide; r++) {
      const o = (g * perGuide + r) * INSTANCE_FLOATS;
      u32[o] = g; u32[o + 1] = g1; u32[o + 2] = g2;
      if (r === 0) {
        f32[o + 3] = 0; f32[o + 4] = 0; f32[o + 5] = 0; f32[o + 6] = 0; f32[o + 7] = 1; f32[o + 8] = 0.5;
        continue;
      }
      let a = rand(), b = rand();
      if (a + b > 1) { a = 1 - a; b = 1 - b; }
      f32[o + 3] = ok1 ? a : 0;
      f32[o + 4] = ok2 ? b : 0;
      const rad = radius * Math.sqrt(rand()), th = 2 * Math.PI * rand();
      f32[o + 5] = rad * Math.cos(th);
      f32[o + 6] = rad * Math.sin(th);
      f32[o + 7] = 1 - lengthJitter * rand();
      f32[o + 8] = rand();
    }
  }
  const guideData = new ArrayBuffer(nguides * INSTANCE_STRIDE);
  const dst = new Uint8Array(guideData), src = new Uint8Array(data);
  for (let g = 0; g < nguides; g++) dst.set(src.subarray(g * perGuide * INSTANCE_STRIDE, (g * perGuide + 1) * INSTANCE_STRIDE), g * INSTANCE_STRIDE);
  return { count, data, guideData, spacing };
}
