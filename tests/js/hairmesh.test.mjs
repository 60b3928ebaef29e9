// Tests web/hairmesh.js: the tracing rule and the even layer parameters (the C ones), render
// strands grown with styling, the render-strand layout and the wireframe.
import test from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import {
  FACE_NONE, MESH_INSTANCE_STRIDE, cornerWeights, evenParams, growPoint, layerAt, meshStrands, strandParams, traceStrand,
  wireframeIndices,
} from '../../web/hairmesh.js';

// A hand-made mesh: 5 columns, 4 layers; a quad (0 1 2 3) and a triangle (1 4 2). Column c's
// layer l sits at its root moved down by heights[l] (5 cm per layer unless given), bent outwards
// in x with l^2.
function handMesh(heights = [0, 0.05, 0.1, 0.15]) {
  const roots = [[0, 0, 0], [0.02, 0, 0], [0.02, 0, 0.02], [0, 0, 0.02], [0.04, 0, 0.01]];
  const ncols = roots.length, nlayers = 4, pos = new Float32Array(3 * ncols * nlayers);
  roots.forEach((r, c) => {
    for (let l = 0; l < nlayers; l++) {
      const b = 3 * (c * nlayers + l);
      pos[b] = r[0] + 0.004 * l * l; pos[b + 1] = r[1] - heights[l]; pos[b + 2] = r[2] + 0.001 * c * l;
    }
  });
  const faces = Uint32Array.of(0, 1, 2, 3, 1, 4, 2, FACE_NONE);
  return { ncols, nlayers, pos, faces, nfaces: 2 };
}

const near = (a, b, tol, what) => assert.ok(Math.abs(a - b) <= tol, `${what}: ${a} vs ${b}`);
// A strand's even layer parameters on the rest mesh m (its pos).
const params = (m, f, u, v, n) => evenParams(m, m.pos, f, u, v, n);
const NO_STYLE = { offset: 0, tipSpread: 1, curl: 0, curlTurns: 0, frizz: 0 };

// Strands the C tracing (core_hairmesh_trace) made, written by tests/test_hairmesh_fixture.c.
const fixture = JSON.parse(readFileSync(new URL('./hairmesh_trace.json', import.meta.url), 'utf8'));

test('the tracing and the grown strands match the C tracing on the fixture', () => {
  assert.equal(fixture.meshes.length, 2);
  let checked = 0, triangles = 0;
  for (const m of fixture.meshes) {
    const mesh = { nlayers: m.nlayers, pos: Float32Array.from(m.pos), faces: Uint32Array.from(m.faces) };
    for (const s of m.strands) {
      const t = evenParams(mesh, mesh.pos, s.face, s.u, s.v, s.nverts);
      for (let i = 0; i < s.nverts; i++) near(t[i], s.t[i], 1e-5, `${m.name} face ${s.face} (${s.u}, ${s.v}) layer parameter ${i}`);
      const ct = Float32Array.from(s.t);
      const got = traceStrand(mesh, s.face, s.u, s.v, s.nverts, ct, new Float64Array(3 * s.nverts));
      const p = [0, 0, 0];
      for (let i = 0; i < 3 * s.nverts; i++) near(got[i], s.xyz[i], 2e-7, `${m.name} face ${s.face} (${s.u}, ${s.v}) coordinate ${i}`);
      for (let i = 0; i < s.nverts; i++) {
        growPoint(mesh, { face: s.face, u: s.u, v: s.v, rand: [0.5, 1, 0.5, 0.5], t: ct }, i, s.nverts, NO_STYLE, p);
        for (let c = 0; c < 3; c++) near(p[c], s.xyz[3 * i + c], 2e-7, `${m.name} grown point ${i}`);
      }
      if (mesh.faces[4 * s.face + 3] === FACE_NONE) triangles++;
      checked++;
    }
  }
  assert.ok(checked >= 18 && triangles >= 3);
});

test('corner weights: bilinear on quads, barycentric on triangles, summing to one', () => {
  const w = [0, 0, 0, 0];
  assert.deepEqual(cornerWeights(4, 0, 0, w), [1, 0, 0, 0]);
  assert.deepEqual(cornerWeights(4, 1, 1, w), [0, 0, 1, 0]);
  assert.deepEqual(cornerWeights(4, 0, 1, w), [0, 0, 0, 1]);
  assert.deepEqual(cornerWeights(3, 0.25, 0.5, w), [0.25, 0.25, 0.5, 0]);
  for (const [u, v] of [[0.3, 0.9], [0.7, 0.1]]) near(cornerWeights(4, u, v, w).reduce((a, b) => a + b), 1, 1e-12, 'sum');
});

test('layer parameters: the last span ends on the tip layer', () => {
  assert.deepEqual(layerAt(0, 4), [0, 0]);
  assert.deepEqual(layerAt(3, 4), [2, 1]);
  assert.deepEqual(layerAt(1.5, 4), [1, 0.5]);
});

test('even parameters: equal segments at rest on uneven layers, root and tip on the end layers', () => {
  const m = handMesh([0, 0.004, 0.09, 0.1]);
  for (const [f, u, v] of [[0, 0.3, 0.6], [1, 0.2, 0.3], [0, 1, 1]]) {
    for (const n of [3, 7, 20]) {
      const t = params(m, f, u, v, n), x = traceStrand(m, f, u, v, n, t, new Float64Array(3 * n));
      assert.equal(t[0], 0);
      assert.equal(t[n - 1], m.nlayers - 1);
      const seg = [];
      for (let i = 0; i + 1 < n; i++) seg.push(Math.hypot(x[3 * i + 3] - x[3 * i], x[3 * i + 4] - x[3 * i + 1], x[3 * i + 5] - x[3 * i + 2]));
      const mean = seg.reduce((a, b) => a + b) / seg.length;
      assert.ok((Math.max(...seg) - Math.min(...seg)) / mean <= 1e-3, `face ${f}, ${n} points: segments ${seg}`);
    }
  }
  // the uniform parameters would not be even: the first span is 4 mm, the next 8.6 cm
  const flat = Float32Array.from({ length: 4 }, (_, i) => i), x = traceStrand(m, 0, 0.5, 0.5, 4, flat, new Float64Array(12));
  assert.ok(Math.hypot(x[3] - x[0], x[4] - x[1], x[5] - x[2]) < 0.1 * Math.hypot(x[6] - x[3], x[7] - x[4], x[8] - x[5]));
  // a strand of zero length: the uniform parameters
  const z = { ...m, pos: new Float32Array(m.pos.length) };
  assert.deepEqual(Array.from(params(z, 0, 0.5, 0.5, 4)), [0, 1, 2, 3]);
  // the render strands' table: strand k's points at k pts
  const strands = meshStrands(m.faces, m.nfaces, 3, 9), table = strandParams(m, m.pos, strands, 5);
  assert.equal(table.length, strands.count * 5);
  const u32 = new Uint32Array(strands.data), f32 = new Float32Array(strands.data), k = 4;
  assert.deepEqual(table.subarray(5 * k, 5 * k + 5), params(m, u32[8 * k], f32[8 * k + 1], f32[8 * k + 2], 5));
});

test('a strand of nlayers vertices passes through the layer points; more vertices lie on the segments', () => {
  const m = handMesh(), u = 0.3, v = 0.6;
  const layers = Float32Array.from({ length: m.nlayers }, (_, i) => i);
  const out = traceStrand(m, 0, u, v, m.nlayers, layers, new Float64Array(3 * m.nlayers));
  const w = cornerWeights(4, u, v, [0, 0, 0, 0]);
  for (let l = 0; l < m.nlayers; l++) {
    for (let c = 0; c < 3; c++) {
      let want = 0;
      for (let k = 0; k < 4; k++) want += w[k] * m.pos[3 * (m.faces[k] * m.nlayers + l) + c];
      near(out[3 * l + c], want, 1e-7, `layer ${l} axis ${c}`);
    }
  }
  const fine = traceStrand(m, 0, u, v, 7, Float32Array.of(0, 0.5, 1, 1.5, 2, 2.5, 3), new Float64Array(21));
  for (let c = 0; c < 3; c++) near(fine[3 * 1 + c], 0.5 * (out[c] + out[3 + c]), 1e-7, `midpoint axis ${c}`);
  // a triangle at corner 2's weights is column 2 itself
  const tri = traceStrand(m, 1, 0, 1, m.nlayers, layers, new Float64Array(12));
  for (let l = 0; l < m.nlayers; l++) for (let c = 0; c < 3; c++) near(tri[3 * l + c], m.pos[3 * (2 * m.nlayers + l) + c], 1e-7, 'corner 2');
});

test('without styling a grown strand is the traced strand, point for point', () => {
  const m = handMesh(), pts = 10, p = [0, 0, 0];
  for (const inst of [{ face: 0, u: 0.2, v: 0.7, rand: [0.3, 0.8, 0.1, 0.5] }, { face: 1, u: 0.3, v: 0.3, rand: [0.9, 0.2, 0.6, 0.5] }]) {
    inst.t = params(m, inst.face, inst.u, inst.v, pts);
    const want = traceStrand(m, inst.face, inst.u, inst.v, pts, inst.t, new Float64Array(3 * pts));
    for (let i = 0; i < pts; i++) {
      growPoint(m, inst, i, pts, NO_STYLE, p);
      for (let c = 0; c < 3; c++) near(p[c], want[3 * i + c], 1e-9, `face ${inst.face} point ${i}`);
    }
  }
});

test('curl circles the traced strand at its radius, perpendicular to the layer direction', () => {
  const m = handMesh(), pts = 13, p = [0, 0, 0], tan = [0, 0, 0];
  const inst = { face: 0, u: 0.5, v: 0.5, rand: [0, 0, 0.25, 0.5], t: params(m, 0, 0.5, 0.5, pts) };
  const style = { ...NO_STYLE, curl: 0.004, curlTurns: 3 };
  const base = traceStrand(m, 0, 0.5, 0.5, pts, inst.t, new Float64Array(3 * pts));
  const offsets = [];
  for (let i = 0; i < pts; i++) {
    growPoint(m, inst, i, pts, style, p, tan);
    const d = [p[0] - base[3 * i], p[1] - base[3 * i + 1], p[2] - base[3 * i + 2]];
    near(Math.hypot(...d), 0.004, 1e-9, `radius at ${i}`);
    const [l] = layerAt(inst.t[i], m.nlayers);
    const T = [0, 1, 2].map((c) => base[3 * Math.min(pts - 1, i + 1) + c] - base[3 * Math.max(0, i - 1) + c]);
    const span = [0, 1, 2].map((c) => {
      let a = 0, b = 0;
      const w = cornerWeights(4, 0.5, 0.5, [0, 0, 0, 0]);
      for (let k = 0; k < 4; k++) { a += w[k] * m.pos[3 * (m.faces[k] * m.nlayers + l) + c]; b += w[k] * m.pos[3 * (m.faces[k] * m.nlayers + l + 1) + c]; }
      return b - a;
    });
    near(d[0] * span[0] + d[1] * span[1] + d[2] * span[2], 0, 1e-9, `perpendicular at ${i}`);
    near(Math.hypot(...tan), 1, 1e-9, 'unit tangent');
    assert.ok(tan[0] * T[0] + tan[1] * T[1] + tan[2] * T[2] > 0, 'the tangent points along the strand');
    offsets.push(d);
  }
  // three turns: the offset comes back to where it started
  for (let c = 0; c < 3; c++) near(offsets[0][c] + offsets[pts - 1][c], 2 * offsets[0][c], 2e-3, 'turns');
});

test('offset grows from root to tip; frizz is zero at the root and bounded', () => {
  const m = handMesh(), pts = 9, p = [0, 0, 0];
  const inst = { face: 0, u: 0.4, v: 0.4, rand: [0.1, 1, 0.3, 0.5], t: params(m, 0, 0.4, 0.4, pts) };
  const base = traceStrand(m, 0, 0.4, 0.4, pts, inst.t, new Float64Array(3 * pts));
  const dist = (i, style) => {
    growPoint(m, inst, i, pts, style, p);
    return Math.hypot(p[0] - base[3 * i], p[1] - base[3 * i + 1], p[2] - base[3 * i + 2]);
  };
  near(dist(0, { ...NO_STYLE, offset: 0.002, tipSpread: 3 }), 0.002, 1e-9, 'root offset');
  near(dist(pts - 1, { ...NO_STYLE, offset: 0.002, tipSpread: 3 }), 0.006, 1e-9, 'tip offset');
  near(dist(0, { ...NO_STYLE, frizz: 0.01 }), 0, 1e-12, 'no frizz at the root');
  let moved = 0;
  for (let i = 1; i < pts; i++) {
    const d = dist(i, { ...NO_STYLE, frizz: 0.01 });
    assert.ok(d <= 0.01 * Math.SQRT2 + 1e-9, `frizz bounded at ${i}`);
    moved = Math.max(moved, d);
  }
  assert.ok(moved > 0.001, 'frizz moves the strand');
});

test('render strands: perFace per face, inside their faces, the same for the same seed', () => {
  const m = handMesh(), a = meshStrands(m.faces, m.nfaces, 50, 5), b = meshStrands(m.faces, m.nfaces, 50, 5);
  assert.equal(a.count, 100);
  assert.equal(a.data.byteLength, 100 * MESH_INSTANCE_STRIDE);
  assert.deepEqual(new Uint8Array(a.data), new Uint8Array(b.data));
  assert.notDeepEqual(new Uint8Array(meshStrands(m.faces, m.nfaces, 50, 6).data), new Uint8Array(a.data));
  const u32 = new Uint32Array(a.data), f32 = new Float32Array(a.data);
  for (let k = 0; k < a.count; k++) {
    const f = u32[8 * k], u = f32[8 * k + 1], v = f32[8 * k + 2];
    assert.equal(f, k < 50 ? 0 : 1);
    assert.ok(u >= 0 && v >= 0 && u <= 1 && v <= 1);
    if (f === 1) assert.ok(u + v <= 1 + 1e-6, 'inside the triangle');
    for (let j = 3; j < 8; j++) assert.ok(f32[8 * k + j] >= 0 && f32[8 * k + j] <= 1);
  }
});

test('wireframe: every layer edge once per layer and every column segment', () => {
  const m = handMesh(), idx = wireframeIndices(m.faces, m.nfaces, m.ncols, m.nlayers);
  // quad 4 edges + triangle 3 edges - the shared edge (1, 2) = 6 edges at 4 layers; 5 columns x 3 segments
  assert.equal(idx.length, 2 * (6 * 4 + 5 * 3));
  for (const k of idx) assert.ok(k < m.ncols * m.nlayers);
});
