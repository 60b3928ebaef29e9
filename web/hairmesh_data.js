// The hair mesh's topology: the /hairmesh.bin binary (proto/PROTOCOL.md, "Hair mesh topology
// binary": faces, traced guides, rest vertices), fetched when hello/groom name a new version.

export const HAIRMESH_MAGIC = 'SCHT';
export const HAIRMESH_VERSION = 1;
export const HAIRMESH_HEADER = 24;
const NONE = 0xffffffff;

// Parses the binary (ArrayBuffer) into { ncols, nlayers, nfaces, nguides, faces: Uint32Array
// (4 nfaces), guideFace: Uint32Array (nguides), guideUV: Float32Array (2 nguides), rest:
// Float32Array (3 ncols nlayers, column-major) }, copies in native order. Throws an Error saying
// what is wrong (magic, version, counts, size, a corner out of range or repeated, a guide's face
// out of range, a value that is not finite).
export function parseHairmeshData(buf) {
  if (!(buf instanceof ArrayBuffer) || buf.byteLength < HAIRMESH_HEADER) throw new Error(`hair mesh binary: ${buf && buf.byteLength} bytes, no header`);
  const dv = new DataView(buf);
  const magic = String.fromCharCode(dv.getUint8(0), dv.getUint8(1), dv.getUint8(2), dv.getUint8(3));
  if (magic !== HAIRMESH_MAGIC) throw new Error(`hair mesh binary: magic "${magic}", expected "${HAIRMESH_MAGIC}"`);
  const [version, ncols, nlayers, nfaces, nguides] = [4, 8, 12, 16, 20].map((o) => dv.getUint32(o, true));
  if (version !== HAIRMESH_VERSION) throw new Error(`hair mesh binary: version ${version}, expected ${HAIRMESH_VERSION}`);
  if (ncols < 3 || nlayers < 2 || nfaces < 1) throw new Error(`hair mesh binary: ${ncols} columns, ${nlayers} layers, ${nfaces} faces`);
  const want = HAIRMESH_HEADER + 16 * nfaces + 12 * nguides + 12 * ncols * nlayers;
  if (want !== buf.byteLength) throw new Error(`hair mesh binary: ${nfaces} faces, ${nguides} guides and ${ncols} x ${nlayers} vertices need ${want} bytes, got ${buf.byteLength}`);
  let o = HAIRMESH_HEADER;
  const faces = new Uint32Array(4 * nfaces);
  for (let f = 0; f < nfaces; f++) {
    for (let k = 0; k < 4; k++, o += 4) faces[4 * f + k] = dv.getUint32(o, true);
    const n = faces[4 * f + 3] === NONE ? 3 : 4;
    for (let k = 0; k < n; k++) {
      const c = faces[4 * f + k];
      if (c >= ncols) throw new Error(`hair mesh binary: face ${f} corner ${k} is column ${c}, past the ${ncols} columns`);
      for (let j = 0; j < k; j++) if (faces[4 * f + j] === c) throw new Error(`hair mesh binary: face ${f} uses column ${c} twice`);
    }
  }
  const guideFace = new Uint32Array(nguides), guideUV = new Float32Array(2 * nguides), rest = new Float32Array(3 * ncols * nlayers);
  for (let g = 0; g < nguides; g++, o += 4) {
    guideFace[g] = dv.getUint32(o, true);
    if (guideFace[g] >= nfaces) throw new Error(`hair mesh binary: guide ${g} is in face ${guideFace[g]}, past the ${nfaces} faces`);
  }
  for (let i = 0; i < guideUV.length; i++, o += 4) {
    guideUV[i] = dv.getFloat32(o, true);
    if (!Number.isFinite(guideUV[i])) throw new Error(`hair mesh binary: guide ${i >> 1}'s coordinates are not finite`);
  }
  for (let i = 0; i < rest.length; i++, o += 4) {
    rest[i] = dv.getFloat32(o, true);
    if (!Number.isFinite(rest[i])) throw new Error(`hair mesh binary: column ${Math.floor(i / 3 / nlayers)} layer ${Math.floor(i / 3) % nlayers} is not finite`);
  }
  return { ncols, nlayers, nfaces, nguides, faces, guideFace, guideUV, rest };
}
