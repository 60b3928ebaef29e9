// Render strands grown from a hair mesh: the tracing rule of server/core/hairmesh_types.h
// (core_hairmesh_trace) and the viewer's styling on top of it, as pure functions. The hair-mesh
// vertex shader (shaders.js HAIRMESH_VS) computes exactly growPoint for every ribbon point; the
// tests check these functions against the C tracing.

import { rng } from './interp.js';

// Marks the missing fourth corner of a triangle (CORE_HAIRMESH_NONE).
export const FACE_NONE = 0xffffffff;

// Bytes per render strand in the instance buffer: uint32 face, float32 (u, v) in the face,
// float32 random [offset angle / 2 pi, offset radius, curl phase / 2 pi, shade], float32 length
// fraction.
export const MESH_INSTANCE_STRIDE = 32;

// The corner weights of (u, v) in a face of n corners (3 or 4) into w[0..3]: bilinear on a quad
// (corners 0, 1, 2, 3 at (0,0), (1,0), (1,1), (0,1)), barycentric on a triangle (corner 0 gets
// 1 - u - v, w[3] = 0).
export function cornerWeights(n, u, v, w) {
  if (n === 4) {
    w[0] = (1 - u) * (1 - v); w[1] = u * (1 - v); w[2] = u * v; w[3] = (1 - u) * v;
  } else {
    w[0] = 1 - u - v; w[1] = u; w[2] = v; w[3] = 0;
  }
  return w;
}

// Corners of face f (3 or 4) in faces (4 column indices per face).
export function faceCorners(faces, f) {
  return faces[4 * f + 3] === FACE_NONE ? 3 : 4;
}

// The layer parameter t of a strand point as [layer l, fraction a]: l = min(floor(t),
// nlayers - 2), a = t - l in float, as C (core_hairmesh_trace) computes it.
export function layerAt(t, nlayers) {
  const l = Math.min(Math.floor(t), nlayers - 2);
  return [l, Math.fround(t - l)];
}

// The even layer parameters of a strand of n >= 2 points at face f, (u, v) of the mesh
// { nlayers, faces } through the REST positions rest (column-major), into a Float32Array(n): the
// rule of server/core/hairmesh_types.h (core_hairmesh_even_params), stated here the same: the
// strand's curve is the polyline of its layer points; t_0 = 0, t_{n-1} = nlayers - 1, and
// consecutive rest points at one straight distance d: from t_i, t_{i+1} is the first parameter
// past t_i whose point lies at distance d from point i (solved exactly on each polyline
// segment); d is found by 64 bisection steps on [0, polyline length / (n - 1)] (a d whose walk of
// n - 1 steps reaches past the tip is too long), the walk of the final lower bound gives t_1 ..
// t_{n-2}. Where that walk's last step (from point n - 2 to the tip-layer point) differs from d
// by more than 1e-4 d (a curve folding back on itself), t_1 .. t_{n-2} are at even arc length
// along the polyline instead. In double from the float positions and float weights; stored in
// float. A strand of zero length gets t_i = i (nlayers - 1) / (n - 1). The viewer computes the
// table once per render strand from the rest mesh and keeps it while the mesh deforms.
export function evenParams(mesh, rest, f, u, v, n, t = new Float32Array(n)) {
  const nlayers = mesh.nlayers, nc = faceCorners(mesh.faces, f);
  const w = cornerWeights(nc, Math.fround(u), Math.fround(v), [0, 0, 0, 0]).map(Math.fround);
  const pts = [];
  for (let l = 0; l < nlayers; l++) pts.push(layerPoint(rest, nlayers, mesh.faces, f, w, l, [0, 0, 0]));
  const pt = (l) => pts[l];
  const top = nlayers - 1;
  let len = 0;
  for (let l = 1; l < nlayers; l++) len += dist3(pt(l - 1), pt(l));
  if (!(len > 0)) {
    for (let i = 0; i < n; i++) t[i] = Math.fround(Math.fround(Math.fround(i) * Math.fround(top)) / Math.fround(n - 1));
    return t;
  }
  let lo = 0, hi = len / (n - 1);
  for (let it = 0; it < 64; it++) {
    const mid = 0.5 * (lo + hi);
    if (walk(pt, nlayers, n, mid, null)) lo = mid; else hi = mid;
  }
  const last = walk(pt, nlayers, n, lo, t) ? dist3(curveAt(pt, nlayers, n > 2 ? t[n - 2] : 0), pt(top)) : -1;
  if (!(Math.abs(last - lo) <= 1e-4 * lo)) arcParams(pt, nlayers, n, len, t);
  t[0] = 0;
  t[n - 1] = top;
  for (let i = 1; i + 1 < n; i++) t[i] = Math.min(t[i], top);
  return t;
}

function dist3(a, b) {
  return Math.sqrt((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) + (b[2] - a[2]) * (b[2] - a[2]));
}

// evenParams' walk of n - 1 straight steps of length d along the curve of layer points pt(l);
// writes the parameters of points 1.. into t when given; false when a step runs past the tip.
function walk(pt, nlayers, n, d, t) {
  let l = 0, a0 = 0, A = pt(0), B = pt(1);
  const p = pt(0).slice();
  for (let i = 1; i < n; i++) {
    for (;;) {
      const e = [B[0] - A[0], B[1] - A[1], B[2] - A[2]], g = [A[0] - p[0], A[1] - p[1], A[2] - p[2]];
      const qa = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
      const qb = 2 * (e[0] * g[0] + e[1] * g[1] + e[2] * g[2]);
      const qc = g[0] * g[0] + g[1] * g[1] + g[2] * g[2] - d * d;
      if (qa > 0) {
        const disc = Math.sqrt(Math.max(qb * qb - 4 * qa * qc, 0));
        const a = qb >= 0 ? (qc < 0 ? 2 * qc / (-qb - disc) : 0) : (-qb + disc) / (2 * qa);
        if (a <= 1) { a0 = Math.max(a, a0); break; }
      }
      if (l + 2 >= nlayers) return false;
      l++; a0 = 0; A = B; B = pt(l + 1);
    }
    for (let c = 0; c < 3; c++) p[c] = A[c] + a0 * (B[c] - A[c]);
    if (t) t[i] = l + a0;
  }
  return true;
}

// The curve's point at layer parameter t (in double).
function curveAt(pt, nlayers, t) {
  const l = Math.min(Math.floor(t), nlayers - 2), a = t - l, p0 = pt(l), p1 = pt(l + 1);
  return [0, 1, 2].map((c) => p0[c] + a * (p1[c] - p0[c]));
}

// evenParams' fallback: points 1 .. n - 2 at even arc length along the polyline of length len.
function arcParams(pt, nlayers, n, len, t) {
  let l = 0, s0 = 0, A = pt(0), B = pt(1), seg = dist3(A, B);
  for (let i = 1; i + 1 < n; i++) {
    const want = (i * len) / (n - 1);
    while (s0 + seg < want && l + 2 < nlayers) {
      s0 += seg; l++; A = B; B = pt(l + 1); seg = dist3(A, B);
    }
    t[i] = l + (seg > 0 ? Math.min((want - s0) / seg, 1) : 0);
  }
}

// Writes to out[o..o+2] the guide point of face f with corner weights w at layer l of a mesh
// whose positions pos are column-major (layer l of column c at 3 (c nlayers + l)).
export function layerPoint(pos, nlayers, faces, f, w, l, out, o = 0) {
  out[o] = 0; out[o + 1] = 0; out[o + 2] = 0;
  const n = faceCorners(faces, f);
  for (let k = 0; k < n; k++) {
    const b = 3 * (faces[4 * f + k] * nlayers + l);
    out[o] += w[k] * pos[b]; out[o + 1] += w[k] * pos[b + 1]; out[o + 2] += w[k] * pos[b + 2];
  }
  return out;
}

// Traces one strand of nverts >= 2 vertices through the mesh { nlayers, pos, faces } at face f,
// (u, v) into out[3 nverts], vertex i at layer parameter t[i] (its even parameters, evenParams;
// core_hairmesh_trace's rule: piecewise linear between the layer points).
export function traceStrand(mesh, f, u, v, nverts, t, out) {
  const w = cornerWeights(faceCorners(mesh.faces, f), u, v, [0, 0, 0, 0]);
  const p0 = [0, 0, 0], p1 = [0, 0, 0];
  for (let i = 0; i < nverts; i++) {
    const [l, a] = layerAt(t[i], mesh.nlayers);
    layerPoint(mesh.pos, mesh.nlayers, mesh.faces, f, w, l, p0);
    layerPoint(mesh.pos, mesh.nlayers, mesh.faces, f, w, l + 1, p1);
    for (let c = 0; c < 3; c++) out[3 * i + c] = p0[c] + a * (p1[c] - p0[c]);
  }
  return out;
}

// The render strands of a mesh of nfaces faces (faces: 4 column indices per face): perFace
// strands at uniformly random points of each face (seeded, so every client draws the same),
// each with its random styling values. Returns { data: ArrayBuffer (MESH_INSTANCE_STRIDE bytes per
// strand), count }.
export function meshStrands(faces, nfaces, perFace, seed = 17) {
  const count = nfaces * perFace, data = new ArrayBuffer(count * MESH_INSTANCE_STRIDE);
  const u32 = new Uint32Array(data), f32 = new Float32Array(data), r = rng(seed);
  for (let f = 0, k = 0; f < nfaces; f++) {
    const tri = faceCorners(faces, f) === 3;
    for (let j = 0; j < perFace; j++, k++) {
      let u = r(), v = r();
      if (tri && u + v > 1) { u = 1 - u; v = 1 - v; }
      const b = 8 * k;
      u32[b] = f; f32[b + 1] = u; f32[b + 2] = v;
      f32[b + 3] = r(); f32[b + 4] = Math.sqrt(r()); f32[b + 5] = r(); f32[b + 6] = r();
      f32[b + 7] = 0.8 + 0.2 * r();
    }
  }
  return { data, count };
}

// The even layer parameters (evenParams on the rest positions rest) of every render strand of
// strands (meshStrands' { data, count }) at pts points: a Float32Array(count pts), strand k's
// point i at k pts + i (the hair-mesh vertex shader's parameter texture).
export function strandParams(mesh, rest, strands, pts) {
  const u32 = new Uint32Array(strands.data), f32 = new Float32Array(strands.data);
  const out = new Float32Array(strands.count * pts);
  for (let k = 0; k < strands.count; k++) {
    const b = (MESH_INSTANCE_STRIDE / 4) * k;
    evenParams(mesh, rest, u32[b], f32[b + 1], f32[b + 2], pts, out.subarray(k * pts, (k + 1) * pts));
  }
  return out;
}

const TAU = 2 * Math.PI;

// Frizz: a smooth pseudo-random wobble of the strand at parameter t (two sine octaves with
// per-strand phases), growing as t^2. Returns the pair of frame coordinates in out.
export function frizz(t, phase, amp, out) {
  const g = amp * t * t;
  out[0] = g * (0.6 * Math.sin(TAU * (7.0 * t + phase)) + 0.4 * Math.sin(TAU * (17.0 * t + 2.3 * phase)));
  out[1] = g * (0.6 * Math.cos(TAU * (5.0 * t + 1.7 * phase)) + 0.4 * Math.sin(TAU * (13.0 * t + phase)));
  return out;
}

// The centre of ribbon point i of pts (pts >= 2) of render strand inst = { face, u, v, rand:
// [angle, radius, phase, shade], t: its pts even layer parameters (evenParams on the rest mesh) }
// grown from the mesh { nlayers, pos, faces } with style s
// ({ offset: m at the root, tipSpread: its factor at the tip, curl: radius in m, curlTurns: turns
// from root to tip, frizz: m at the tip }; the View panel's meshOffset, tipSpread, curl,
// curlTurns and frizz) into out[0..2]; its unit tangent (the layer
// direction, bent by the curl) into tan[0..2] when given. The traced point (traceStrand with pts
// vertices at inst.t) plus, in the frame (E, F) of the face at that point (E: corner 0 to corner 1,
// normalised; F = T x E, normalised; T the layer direction), the offset
// s.offset * mix(1, s.tipSpread, t) * radius * (cos, sin)(2 pi angle), the curl
// s.curl * (cos, sin)(2 pi (s.curlTurns t + phase)) and frizz(t, phase, s.frizz), with t = i / (pts - 1).
export function growPoint(mesh, inst, i, pts, s, out, tan = null) {
  const { nlayers, pos, faces } = mesh, f = inst.face;
  const w = cornerWeights(faceCorners(faces, f), inst.u, inst.v, [0, 0, 0, 0]);
  const [l, a] = layerAt(inst.t[i], nlayers);
  const p0 = layerPoint(pos, nlayers, faces, f, w, l, [0, 0, 0]);
  const p1 = layerPoint(pos, nlayers, faces, f, w, l + 1, [0, 0, 0]);
  const e0 = edge(pos, nlayers, faces, f, l, a);
  let T = [p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]];
  T = normalize(T, [0, -1, 0]);
  const ed = e0[0] * T[0] + e0[1] * T[1] + e0[2] * T[2];
  const E = normalize([e0[0] - ed * T[0], e0[1] - ed * T[1], e0[2] - ed * T[2]], perpendicular(T));
  const F = [T[1] * E[2] - T[2] * E[1], T[2] * E[0] - T[0] * E[2], T[0] * E[1] - T[1] * E[0]];
  const t = i / (pts - 1);
  const [ang, rad, ph] = inst.rand;
  const sp = s.offset * (1 + (s.tipSpread - 1) * t) * rad;
  const cph = TAU * (s.curlTurns * t + ph);
  const fz = frizz(t, ph, s.frizz, [0, 0]);
  const x = sp * Math.cos(TAU * ang) + s.curl * Math.cos(cph) + fz[0];
  const y = sp * Math.sin(TAU * ang) + s.curl * Math.sin(cph) + fz[1];
  for (let c = 0; c < 3; c++) out[c] = p0[c] + a * (p1[c] - p0[c]) + x * E[c] + y * F[c];
  if (tan) {
    // d/dt of the traced point (layer span length times layer parameters per unit t, from the
    // table's step at i, the step before it at the tip) plus the curl's turning
    const k = Math.min(i, pts - 2);
    const span = Math.hypot(p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]) * (inst.t[k + 1] - inst.t[k]) * (pts - 1);
    const dc = TAU * s.curlTurns * s.curl;
    for (let c = 0; c < 3; c++) tan[c] = span * T[c] + dc * (-Math.sin(cph) * E[c] + Math.cos(cph) * F[c]);
    normalize(tan, T, tan);
  }
  return out;
}

// The direction from corner 0 to corner 1 of face f, blended between layers l and l + 1 by a.
function edge(pos, nlayers, faces, f, l, a) {
  const c0 = faces[4 * f], c1 = faces[4 * f + 1], e = [0, 0, 0];
  for (let c = 0; c < 3; c++) {
    const d0 = pos[3 * (c1 * nlayers + l) + c] - pos[3 * (c0 * nlayers + l) + c];
    const d1 = pos[3 * (c1 * nlayers + l + 1) + c] - pos[3 * (c0 * nlayers + l + 1) + c];
    e[c] = d0 + a * (d1 - d0);
  }
  return e;
}

function normalize(v, fallback, out = v) {
  const n = Math.hypot(v[0], v[1], v[2]);
  if (!(n > 1e-12)) { out[0] = fallback[0]; out[1] = fallback[1]; out[2] = fallback[2]; return out; }
  out[0] = v[0] / n; out[1] = v[1] / n; out[2] = v[2] / n;
  return out;
}

// A unit vector perpendicular to the unit vector t (for a face edge along the layer direction).
function perpendicular(t) {
  const a = Math.abs(t[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
  const d = a[0] * t[0] + a[1] * t[1] + a[2] * t[2];
  return normalize([a[0] - d * t[0], a[1] - d * t[1], a[2] - d * t[2]], [0, 0, 1]);
}

// The mesh's wireframe: every layer edge of every face at every layer, and the column edges
// between layers, as pairs of vertex indices (index = column * nlayers + layer, the order of
// the positions). Each shared layer edge once. Returns a Uint32Array.
export function wireframeIndices(faces, nfaces, ncols, nlayers) {
  const seen = new Set(), pairs = [];
  for (let f = 0; f < nfaces; f++) {
    const n = faceCorners(faces, f);
    for (let k = 0; k < n; k++) {
      const a = faces[4 * f + k], b = faces[4 * f + ((k + 1) % n)];
      const key = a < b ? a * ncols + b : b * ncols + a;
      if (seen.has(key)) continue;
      seen.add(key);
      for (let l = 0; l < nlayers; l++) pairs.push(a * nlayers + l, b * nlayers + l);
    }
  }
  for (let c = 0; c < ncols; c++) for (let l = 0; l + 1 < nlayers; l++) pairs.push(c * nlayers + l, c * nlayers + l + 1);
  return Uint32Array.from(pairs);
}
