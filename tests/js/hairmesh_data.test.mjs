// web/hairmesh_data.js: the /hairmesh.bin parser against the layout of proto/PROTOCOL.md.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { parseHairmeshData } from '../../web/hairmesh_data.js';

const NONE = 0xffffffff;
const FACES = [0, 1, 2, 3, 1, 4, 2, NONE];

// The binary written by hand from the documented layout: 5 columns x 3 layers, a quad and a
// triangle, two guides.
function binary({ magic = 'SCHT', version = 1, ncols = 5, nlayers = 3, faces = FACES, gface = [0, 1], guv = [0.25, 0.5, 0.2, 0.3], rest } = {}) {
  const nfaces = faces.length / 4, nguides = gface.length;
  const pos = rest ?? Array.from({ length: 3 * ncols * nlayers }, (_, i) => 0.01 * i);
  const buf = new ArrayBuffer(24 + 16 * nfaces + 12 * nguides + 4 * pos.length);
  const dv = new DataView(buf);
  for (let i = 0; i < 4; i++) dv.setUint8(i, magic.charCodeAt(i));
  [version, ncols, nlayers, nfaces, nguides].forEach((v, i) => dv.setUint32(4 + 4 * i, v, true));
  let o = 24;
  for (const c of faces) { dv.setUint32(o, c, true); o += 4; }
  for (const f of gface) { dv.setUint32(o, f, true); o += 4; }
  for (const x of [...guv, ...pos]) { dv.setFloat32(o, x, true); o += 4; }
  return buf;
}

test('parses the documented layout', () => {
  const d = parseHairmeshData(binary());
  assert.deepEqual([d.ncols, d.nlayers, d.nfaces, d.nguides], [5, 3, 2, 2]);
  assert.deepEqual(Array.from(d.faces), FACES);
  assert.deepEqual(Array.from(d.guideFace), [0, 1]);
  assert.deepEqual(Array.from(d.guideUV), [0.25, 0.5, 0.2, 0.3].map(Math.fround));
  assert.equal(d.rest.length, 45);
  assert.equal(d.rest[44], Math.fround(0.44));
});

test('refuses bad binaries with a reason', () => {
  const nan = Array.from({ length: 45 }, (_, i) => (i === 40 ? NaN : 0));
  const cases = [
    [new ArrayBuffer(20), /no header/],
    [binary({ magic: 'SCGR' }), /magic "SCGR"/],
    [binary({ version: 2 }), /version 2/],
    [binary({ nlayers: 1, rest: new Array(15).fill(0) }), /5 columns, 1 layers/],
    [binary().slice(0, 250), /need 260 bytes, got 250/],
    [binary({ faces: [0, 9, 2, 3] }), /face 0 corner 1 is column 9, past the 5 columns/],
    [binary({ faces: [0, 1, 2, 3, 1, 4, 2, 4] }), /face 1 uses column 4 twice/],
    [binary({ gface: [0, 2] }), /guide 1 is in face 2, past the 2 faces/],
    [binary({ guv: [NaN, 0, 0, 0] }), /guide 0's coordinates are not finite/],
    [binary({ rest: nan }), /column 4 layer 1 is not finite/],
  ];
  for (const [buf, re] of cases) assert.throws(() => parseHairmeshData(buf), re);
});
