// The groom's per-strand data: the /groom.bin binary (proto/PROTOCOL.md, "Groom data binary":
// rest segment lengths and rest roots), fetched when hello/groom name a new version.
// The HTTP base of a strandcastd WebSocket URL (ws://h:p/ -> http://h:p/; a room's,
// ws://h:p/rooms/NAME -> http://h:p/rooms/NAME/, whose binaries are served under its path, so
// that an edge relay serving many rooms serves each room's own).
export function httpBase(wsUrl) {
  const http = String(wsUrl).replace(/^ws(s?):/, 'http$1:');
  const m = /^(https?:\/\/[^/]+)(\/rooms\/[^/?#]+)?/.exec(http);
  return m ? `${m[1]}${m[2] || ''}/` : http;
}

// The URL of a binary a hello or groom message names (url "/groom.bin") on the server of base.
export function blobUrl(url, base) {
  return new URL(String(url).replace(/^\//, ''), base).toString();
}

export const GROOM_MAGIC = 'SCGR';
export const GROOM_VERSION = 1;
export const GROOM_HEADER = 16;

// Parses the binary (ArrayBuffer) into { strands, verts, restLengths: Float32Array (strands),
// roots: Float32Array (3 strands) }, copies in native order. Throws an Error saying what is
// wrong (magic, version, counts, size, a length or root that is not finite).
export function parseGroomData(buf) {
  if (!(buf instanceof ArrayBuffer) || buf.byteLength < GROOM_HEADER) throw new Error(`groom data: ${buf && buf.byteLength} bytes, no header`);
  const dv = new DataView(buf);
  const magic = String.fromCharCode(dv.getUint8(0), dv.getUint8(1), dv.getUint8(2), dv.getUint8(3));
  if (magic !== GROOM_MAGIC) throw new Error(`groom data: magic "${magic}", expected "${GROOM_MAGIC}"`);
  const version = dv.getUint32(4, true), strands = dv.getUint32(8, true), verts = dv.getUint32(12, true);
  if (version !== GROOM_VERSION) throw new Error(`groom data: version ${version}, expected ${GROOM_VERSION}`);
  if (strands < 1 || verts < 2) throw new Error(`groom data: ${strands} strands of ${verts} vertices`);
  const want = GROOM_HEADER + 16 * strands;
  if (want !== buf.byteLength) throw new Error(`groom data: ${strands} strands need ${want} bytes, got ${buf.byteLength}`);
  const restLengths = new Float32Array(strands), roots = new Float32Array(3 * strands);
  for (let s = 0, o = GROOM_HEADER; s < strands; s++, o += 4) {
    const f = dv.getFloat32(o, true);
    if (!Number.isFinite(f) || f < 0) throw new Error(`groom data: strand ${s}'s rest length is not a finite length`);
    restLengths[s] = f;
  }
  for (let i = 0, o = GROOM_HEADER + 4 * strands; i < roots.length; i++, o += 4) {
    const f = dv.getFloat32(o, true);
    if (!Number.isFinite(f)) throw new Error(`groom data: strand ${Math.floor(i / 3)}'s root is not finite`);
    roots[i] = f;
  }
  return { strands, verts, restLengths, roots };
}

// Follows the groom descriptions of hello and groom messages: update(groom, extra) calls
// onGroom(groom, data, extra) once the data of that groom is at hand: at once when groom.etag
// is the version already held, else after fetching groom.url (relative to base). A reply
// whose ETag is not groom.etag (the groom changed again meanwhile) is dropped: the groom
// message naming the new version is on its way. An update superseded by a newer one before its
// data arrived never calls onGroom. onError(message) on a failed fetch or a bad binary, or a
// description without url/etag. fetchFn: fetch.
export class GroomDataLoader {
  constructor(base, onGroom, onError, fetchFn) {
    this.base = base;
    this.onGroom = onGroom;
    this.onError = onError || (() => {});
    this.fetch = fetchFn || ((...a) => fetch(...a));
    this.wanted = null; // etag of the groom waited for
    this.held = null;   // { etag, data } of the last parsed binary
  }

  update(groom, extra) {
    if (!groom || typeof groom.url !== 'string' || typeof groom.etag !== 'string') {
      this.wanted = null;
      this.onError('the groom description names no data binary (url, etag)');
      return Promise.resolve();
    }
    const etag = this.wanted = groom.etag;
    if (this.held && this.held.etag === etag) {
      this.onGroom(groom, this.held.data, extra);
      return Promise.resolve();
    }
    const url = blobUrl(groom.url, this.base);
    return this.fetch(url, { cache: 'no-cache' })
      .then((r) => {
        if (!r.ok) throw new Error(`GET ${groom.url}: HTTP ${r.status}`);
        const tag = (r.headers && r.headers.get('ETag')) || '';
        return r.arrayBuffer().then((buf) => ({ buf, tag }));
      })
      .then(({ buf, tag }) => {
        if (this.wanted !== etag || (tag && tag.replace(/"/g, '') !== etag)) return; // superseded
        const data = parseGroomData(buf);
        if (data.strands !== groom.strands || data.verts !== groom.verts) {
          throw new Error(`groom data: ${data.strands} strands of ${data.verts} vertices, the server said ${groom.strands} of ${groom.verts}`);
        }
        this.held = { etag, data };
        this.onGroom(groom, data, extra);
      })
      .catch((e) => {
        if (this.wanted === etag) this.onError(e.message);
      });
  }
}
