// web/groom_data.js: the /groom.bin parser (the layout of proto/PROTOCOL.md) and the loader that
// follows hello/groom's groom description.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { GroomDataLoader, parseGroomData } from '../../web/groom_data.js';

const LENS = [0.01, 0.02, 0.03];
const ROOTS = [0, 0.1, 0, 0.1, 0.1, 0, 0.2, 0.1, 0.05];

// The binary written by hand from the documented layout: little-endian header, then arrays.
function binary(lens = LENS, roots = ROOTS, { magic = 'SCGR', version = 1, strands = lens.length, verts = 4 } = {}) {
  const buf = new ArrayBuffer(16 + 4 * lens.length + 4 * roots.length);
  const dv = new DataView(buf);
  for (let i = 0; i < 4; i++) dv.setUint8(i, magic.charCodeAt(i));
  dv.setUint32(4, version, true);
  dv.setUint32(8, strands, true);
  dv.setUint32(12, verts, true);
  lens.forEach((v, i) => dv.setFloat32(16 + 4 * i, v, true));
  roots.forEach((v, i) => dv.setFloat32(16 + 4 * lens.length + 4 * i, v, true));
  return buf;
}

test('parses the documented layout', () => {
  const d = parseGroomData(binary());
  assert.equal(d.strands, 3);
  assert.equal(d.verts, 4);
  assert.deepEqual(Array.from(d.restLengths), LENS.map(Math.fround));
  assert.deepEqual(Array.from(d.roots), ROOTS.map(Math.fround));
  assert.ok(d.roots instanceof Float32Array && d.restLengths instanceof Float32Array);
});

test('refuses bad binaries with a reason', () => {
  const cases = [
    [new ArrayBuffer(8), /no header/],
    [binary(LENS, ROOTS, { magic: 'SCMH' }), /magic/],
    [binary(LENS, ROOTS, { version: 2 }), /version 2/],
    [binary(LENS, ROOTS, { verts: 1 }), /3 strands of 1 vertices/],
    [binary(LENS, ROOTS, { strands: 4 }), /need/],
    [binary(LENS, ROOTS).slice(0, 60), /need/],
    [binary([0.01, NaN, 0.03]), /strand 1's rest length/],
    [binary([0.01, -1, 0.03]), /strand 1's rest length/],
    [binary(LENS, [0, 0, 0, 0, 0, 0, 0, Infinity, 0]), /strand 2's root/],
  ];
  for (const [buf, re] of cases) assert.throws(() => parseGroomData(buf), re);
});

test('the loader fetches a new etag once, drops superseded replies and checks the counts', async () => {
  const got = [], errors = [], urls = [];
  let tag = '"aaaa"';
  const fetchFn = async (url) => {
    urls.push(url);
    return { ok: true, status: 200, headers: { get: () => tag }, arrayBuffer: async () => binary() };
  };
  const l = new GroomDataLoader('http://h:1/', (g, d, extra) => got.push([g, d, extra]), (e) => errors.push(e), fetchFn);
  const groom = { strands: 3, verts: 4, url: '/groom.bin', etag: 'aaaa' };
  await l.update(groom, 'colliders-1');
  assert.deepEqual(urls, ['http://h:1/groom.bin']);
  assert.equal(got.length, 1);
  assert.equal(got[0][1].roots.length, 9);
  assert.equal(got[0][2], 'colliders-1');
  // the same version again (a groom message that changed only the colliders): no fetch, applied at once
  await l.update(groom, 'colliders-2');
  assert.equal(urls.length, 1);
  assert.equal(got.length, 2);
  assert.equal(got[1][1], got[0][1]);
  assert.equal(got[1][2], 'colliders-2');
  // the server's bytes already changed again: the reply is dropped, no error
  await l.update({ ...groom, etag: 'bbbb' });
  assert.equal(got.length, 2);
  assert.deepEqual(errors, []);
  // an update superseded while its fetch is under way is dropped too
  tag = '"cccc"';
  const slow = l.update({ ...groom, etag: 'cccc' });
  tag = '"dddd"';
  await l.update({ ...groom, etag: 'dddd' });
  await slow;
  assert.equal(got.length, 3);
  assert.equal(got[2][0].etag, 'dddd');
  // counts that disagree with the description are an error; so are a failed fetch and no url
  tag = '"eeee"';
  await l.update({ ...groom, etag: 'eeee', strands: 5 });
  assert.match(errors[0], /the server said 5 of 4/);
  const failing = new GroomDataLoader('http://h:1/', () => assert.fail('no groom'), (e) => errors.push(e),
    async () => ({ ok: false, status: 404, headers: { get: () => '' } }));
  await failing.update(groom);
  assert.match(errors[1], /HTTP 404/);
  await failing.update({ strands: 3, verts: 4 });
  assert.match(errors[2], /names no data binary/);
});
