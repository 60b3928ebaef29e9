// The character's collision mesh: the /collider.bin binary (proto/PROTOCOL.md, "Collision mesh
// binary"), its smooth normals, and fetching it when hello/groom name a new version.
import { blobUrl, httpBase } from './groom_data.js';

export const MESH_MAGIC = 'SCMH';
export const MESH_VERSION = 1;
export const MESH_HEADER = 16;

// Parses the binary (ArrayBuffer) into { nverts, ntris, positions: Float32Array (3 nverts),
// indices: Uint32Array (3 ntris) }, copies in native order. Throws an Error saying what is
// wrong (magic, version, size, a non-finite position, an index out of range).
export function parseColliderMesh(buf) {
  if (!(buf instanceof ArrayBuffer) || buf.byteLength < MESH_HEADER) throw new Error(`collider mesh: ${buf && buf.byteLength} bytes, no header`);
  const dv = new DataView(buf);
  const magic = String.fromCharCode(dv.getUint8(0), dv.getUint8(1), dv.getUint8(2), dv.getUint8(3));
  if (magic !== MESH_MAGIC) throw new Error(`collider mesh: magic "${magic}", expected "${MESH_MAGIC}"`);
  const version = dv.getUint32(4, true), nverts = dv.getUint32(8, true), ntris = dv.getUint32(12, true);
  if (version !== MESH_VERSION) throw new Error(`collider mesh: version ${version}, expected ${MESH_VERSION}`);
  const want = MESH_HEADER + 12 * nverts + 12 * ntris;
  if (want !== buf.byteLength) throw new Error(`collider mesh: ${nverts} vertices and ${ntris} triangles need ${want} bytes, got ${buf.byteLength}`);
  const positions = new Float32Array(3 * nverts), indices = new Uint32Array(3 * ntris);
  for (let i = 0, o = MESH_HEADER; i < positions.length; i++, o += 4) {
    const f = dv.getFloat32(o, true);
    if (!Number.isFinite(f)) throw new Error(`collider mesh: vertex ${Math.floor(i / 3)} is not finite`);
    positions[i] = f;
  }
  for (let i = 0, o = MESH_HEADER + 12 * nverts; i < indices.length; i++, o += 4) {
    const k = dv.getUint32(o, true);
    if (k >= nverts) throw new Error(`collider mesh: triangle ${Math.floor(i / 3)} uses vertex ${k} of ${nverts}`);
    indices[i] = k;
  }
  return { nverts, ntris, positions, indices };
}

// Area-weighted vertex normals (unit; +y for a vertex no triangle gives a direction).
export function meshNormals(positions, indices) {
  const n = new Float32Array(positions.length);
  for (let t = 0; t < indices.length; t += 3) {
    const a = 3 * indices[t], b = 3 * indices[t + 1], c = 3 * indices[t + 2];
    const ux = positions[b] - positions[a], uy = positions[b + 1] - positions[a + 1], uz = positions[b + 2] - positions[a + 2];
    const vx = positions[c] - positions[a], vy = positions[c + 1] - positions[a + 1], vz = positions[c + 2] - positions[a + 2];
    const nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx; // 2 x area, outward
    for (const k of [a, b, c]) { n[k] += nx; n[k + 1] += ny; n[k + 2] += nz; }
  }
  for (let i = 0; i < n.length; i += 3) {
    const l = Math.hypot(n[i], n[i + 1], n[i + 2]);
    if (l > 0) { n[i] /= l; n[i + 1] /= l; n[i + 2] /= l; } else { n[i] = 0; n[i + 1] = 1; n[i + 2] = 0; }
  }
  return n;
}

export { blobUrl, httpBase }; // (groom_data.js) where the viewer's loaders find a room's binaries

// Keeps the drawn mesh in step with the collider_mesh descriptions of hello and groom:
// update(desc) fetches desc.url (relative to base) when desc.etag is new, and calls
// onMesh(parsed mesh with normals, desc) or onMesh(null, null) for no mesh; a reply whose ETag
// is not desc.etag (the groom changed again meanwhile) is dropped, the next groom message
// brings its own. onError(message) on a failed fetch or a bad binary. fetchFn: fetch.
export class ColliderMeshLoader {
  constructor(base, onMesh, onError, fetchFn) {
    this.base = base;
    this.onMesh = onMesh;
    this.onError = onError || (() => {});
    this.fetch = fetchFn || ((...a) => fetch(...a));
    this.etag = null;  // of the mesh wanted now (being fetched or drawn)
    this.shown = null; // of the mesh handed to onMesh
  }

  update(desc) {
    if (!desc || typeof desc !== 'object' || typeof desc.url !== 'string' || typeof desc.etag !== 'string') {
      if (this.shown !== null) this.onMesh(null, null);
      this.etag = this.shown = null;
      return Promise.resolve();
    }
    if (desc.etag === this.etag) return Promise.resolve();
    const etag = this.etag = desc.etag;
    const url = blobUrl(desc.url, this.base);
    return this.fetch(url, { cache: 'no-cache' })
      .then((r) => {
        if (!r.ok) throw new Error(`GET ${desc.url}: HTTP ${r.status}`);
        const tag = (r.headers && r.headers.get('ETag')) || '';
        return r.arrayBuffer().then((buf) => ({ buf, tag }));
      })
      .then(({ buf, tag }) => {
        if (this.etag !== etag || (tag && tag.replace(/"/g, '') !== etag)) return; // superseded
        const m = parseColliderMesh(buf);
        if (m.nverts !== desc.verts || m.ntris !== desc.triangles) throw new Error(`collider mesh: ${m.nverts} vertices / ${m.ntris} triangles, the server said ${desc.verts} / ${desc.triangles}`);
        m.normals = meshNormals(m.positions, m.indices);
        this.shown = etag;
        this.onMesh(m, desc);
      })
      .catch((e) => {
        if (this.etag === etag) this.etag = null; // retried with the next description
        this.onError(e.message);
      });
  }
}
