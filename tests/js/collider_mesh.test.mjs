// web/collider_mesh.js: the /collider.bin parser (the layout of proto/PROTOCOL.md), normals and
// the loader that follows hello/groom's collider_mesh.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { ColliderMeshLoader, blobUrl, httpBase, meshNormals, parseColliderMesh } from '../../web/collider_mesh.js';

// A tetrahedron, counter-clockwise seen from outside (as the server's meshes are).
const TET_POS = [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1];
const TET_TRI = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3];

// The binary written by hand from the documented layout: little-endian header, then arrays.
function binary(pos = TET_POS, tri = TET_TRI, { magic = 'SCMH', version = 1, nverts = pos.length / 3, ntris = tri.length / 3 } = {}) {
  const buf = new ArrayBuffer(16 + 4 * pos.length + 4 * tri.length);
  const dv = new DataView(buf);
  for (let i = 0; i < 4; i++) dv.setUint8(i, magic.charCodeAt(i));
  dv.setUint32(4, version, true);
  dv.setUint32(8, nverts, true);
  dv.setUint32(12, ntris, true);
  pos.forEach((v, i) => dv.setFloat32(16 + 4 * i, v, true));
  tri.forEach((v, i) => dv.setUint32(16 + 4 * pos.length + 4 * i, v, true));
  return buf;
}

test('parses the documented layout', () => {
  const m = parseColliderMesh(binary());
  assert.equal(m.nverts, 4);
  assert.equal(m.ntris, 4);
  assert.deepEqual(Array.from(m.positions), TET_POS);
  assert.deepEqual(Array.from(m.indices), TET_TRI);
  assert.ok(m.indices instanceof Uint32Array && m.positions instanceof Float32Array);
});

test('refuses bad binaries with a reason', () => {
  const cases = [
    [new ArrayBuffer(8), /no header/],
    [binary(TET_POS, TET_TRI, { magic: 'SCF1' }), /magic/],
    [binary(TET_POS, TET_TRI, { version: 2 }), /version 2/],
    [binary(TET_POS, TET_TRI, { ntris: 5 }), /need/],
    [binary(TET_POS, TET_TRI).slice(0, 100), /need/],
    [binary([NaN, ...TET_POS.slice(1)]), /vertex 0 is not finite/],
    [binary(TET_POS, [0, 2, 4, ...TET_TRI.slice(3)]), /triangle 0 uses vertex 4 of 4/],
  ];
  for (const [buf, re] of cases) assert.throws(() => parseColliderMesh(buf), re);
});

test('normals point outward', () => {
  const m = parseColliderMesh(binary());
  const n = meshNormals(m.positions, m.indices);
  // vertex 1 (1,0,0): away from the centroid (0.25,0.25,0.25)
  const d = [1 - 0.25, -0.25, -0.25];
  assert.ok(n[3] * d[0] + n[4] * d[1] + n[5] * d[2] > 0);
  for (let i = 0; i < 4; i++) assert.ok(Math.abs(Math.hypot(n[3 * i], n[3 * i + 1], n[3 * i + 2]) - 1) < 1e-6);
});

test('httpBase', () => {
  assert.equal(httpBase('ws://127.0.0.1:7681/'), 'http://127.0.0.1:7681/');
  assert.equal(httpBase('wss://h/'), 'https://h/');
  assert.equal(httpBase('ws://h:1/rooms/studio-2'), 'http://h:1/rooms/studio-2/');
  assert.equal(blobUrl('/groom.bin', httpBase('ws://h:1/')), 'http://h:1/groom.bin');
  assert.equal(blobUrl('/groom.bin', httpBase('wss://h/rooms/a_b')), 'https://h/rooms/a_b/groom.bin');
});

test('the loader fetches a new etag once, drops superseded replies and clears on null', async () => {
  const got = [], errors = [], urls = [];
  let tag = '"aaaa"';
  const fetchFn = async (url) => {
    urls.push(url);
    return { ok: true, status: 200, headers: { get: () => tag }, arrayBuffer: async () => binary() };
  };
  const l = new ColliderMeshLoader('http://h:1/', (m, d) => got.push([m, d]), (e) => errors.push(e), fetchFn);
  const desc = { url: '/collider.bin', etag: 'aaaa', verts: 4, triangles: 4 };
  await l.update(desc);
  await l.update(desc); // same version: no fetch
  assert.deepEqual(urls, ['http://h:1/collider.bin']);
  assert.equal(got.length, 1);
  assert.equal(got[0][0].ntris, 4);
  assert.equal(got[0][0].normals.length, 12);
  // the server's bytes already changed again: the reply is dropped, no error
  await l.update({ ...desc, etag: 'bbbb' });
  assert.equal(got.length, 1);
  assert.deepEqual(errors, []);
  // counts that disagree with the description are an error
  tag = '"cccc"';
  await l.update({ ...desc, etag: 'cccc', verts: 5 });
  assert.equal(errors.length, 1);
  assert.match(errors[0], /the server said 5/);
  await l.update(null);
  assert.deepEqual(got[got.length - 1], [null, null]);
});
