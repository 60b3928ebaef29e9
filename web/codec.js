// Strand frame decoder (proto/CODEC.md), bit-exact with server/codec; browser, Worker or Node.

export const HEADER_SIZE = 68;
export const FORMAT_VERSION = 1;
export const CODEC_ID_STRAND = 1;
export const FLAG_KEY = 1;

const MAGIC = [0x53, 0x43, 0x46, 0x31]; // "SCF1"
const SCALE_BITS = 12;
const SCALE = 1 << SCALE_BITS;
const RANS_L = 1 << 23;
const NCLASS = 7;
const ESCAPE = 6;
const NSYM = NCLASS * NCLASS * NCLASS;
const KEY_MODES = 3;
const DELTA_MODES = 4;
const NBODY = 6;
const T_MODE = 0;
const T_ROOT = 1;
const T_FIRST = 2;
const T_BODY = 3;
const NTABLES = T_BODY + NBODY;
const MAX_VERTICES = 1 << 24;
const MAX_NVERTS = 4096;
const MAX_QUANT = 1 << 26;

// Per symbol: the three classes, the table of the next vertex, the raw bit count (-1: escape).
const SYM_C0 = new Uint8Array(NSYM);
const SYM_C1 = new Uint8Array(NSYM);
const SYM_C2 = new Uint8Array(NSYM);
const SYM_NEXT = new Uint8Array(NSYM);
const SYM_BITS = new Int8Array(NSYM);
for (let s = 0; s < NSYM; s++) {
  const c0 = s % NCLASS, c1 = Math.floor(s / NCLASS) % NCLASS, c2 = Math.floor(s / (NCLASS * NCLASS));
  SYM_C0[s] = c0;
  SYM_C1[s] = c1;
  SYM_C2[s] = c2;
  SYM_NEXT[s] = T_BODY + Math.min(Math.max(c0, c1, c2), NBODY - 1);
  SYM_BITS[s] = c0 === ESCAPE || c1 === ESCAPE || c2 === ESCAPE ? -1 : c0 + c1 + c2;
}

const CRC_TABLE = new Int32Array(256 * 4);
for (let n = 0; n < 256; n++) {
  let c = n;
  for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
  CRC_TABLE[n] = c;
}
for (let n = 0; n < 256; n++) {
  for (let t = 1; t < 4; t++) {
    const p = CRC_TABLE[(t - 1) * 256 + n];
    CRC_TABLE[t * 256 + n] = CRC_TABLE[p & 0xff] ^ (p >>> 8);
  }
}

// zlib CRC-32 of bytes[from, to), continuing from crc (0 to start).
function crc32(bytes, from, to, crc) {
  let c = ~crc;
  let i = from;
  for (; i + 4 <= to; i += 4) {
    c ^= bytes[i] | (bytes[i + 1] << 8) | (bytes[i + 2] << 16) | (bytes[i + 3] << 24);
    c = CRC_TABLE[768 + (c & 0xff)] ^ CRC_TABLE[512 + ((c >>> 8) & 0xff)] ^
        CRC_TABLE[256 + ((c >>> 16) & 0xff)] ^ CRC_TABLE[c >>> 24];
  }
  for (; i < to; i++) c = CRC_TABLE[(c ^ bytes[i]) & 0xff] ^ (c >>> 8);
  return ~c >>> 0;
}

function u16(b, o) { return b[o] | (b[o + 1] << 8); }
function u32(b, o) { return (b[o] | (b[o + 1] << 8) | (b[o + 2] << 16) | (b[o + 3] << 24)) >>> 0; }
function u64(b, o) { return u32(b, o) + u32(b, o + 4) * 4294967296; } // exact below 2^53

const fail = (msg) => { throw new Error('codec: ' + msg); };

// Scratch for reading IEEE fields without allocating per frame.
const SCRATCH = new DataView(new ArrayBuffer(8));
function f64(b, o) { for (let k = 0; k < 8; k++) SCRATCH.setUint8(k, b[o + k]); return SCRATCH.getFloat64(0, true); }
function f32(b, o) { for (let k = 0; k < 4; k++) SCRATCH.setUint8(k, b[o + k]); return SCRATCH.getFloat32(0, true); }

/** A fresh header record (fields as in codec_frame_info). */
export function newFrameInfo() {
  return {
    seq: 0, refSeq: 0, simTime: 0, step: 0, maxError: 0, keyframe: false,
    nstrandsTotal: 0, nstrandsSent: 0, nverts: 0, stride: 0, payloadLen: 0, frameLen: 0,
  };
}

/**
 * Parses and validates the fixed header of `bytes` (a Uint8Array holding exactly one frame) into
 * `info` (a newFrameInfo() record, reused; a new one when omitted). Throws Error on a bad header.
 * Does not check the CRC. Sequence numbers above 2^53 lose precision.
 */
export function peekHeader(bytes, info = newFrameInfo()) {
  if (!(bytes instanceof Uint8Array)) fail('frame must be a Uint8Array');
  const len = bytes.length;
  if (len < HEADER_SIZE) fail(`truncated header (${len} bytes, need ${HEADER_SIZE})`);
  for (let k = 0; k < 4; k++) if (bytes[k] !== MAGIC[k]) fail('bad magic (not a strand frame)');
  const version = u16(bytes, 4);
  if (version !== FORMAT_VERSION) fail(`unsupported format version ${version} (this decoder reads ${FORMAT_VERSION})`);
  if (bytes[6] !== CODEC_ID_STRAND) fail(`unknown codec id ${bytes[6]}`);
  const flags = bytes[7];
  if (flags & ~FLAG_KEY) fail(`unknown flags 0x${flags.toString(16)}`);
  const keyframe = (flags & FLAG_KEY) !== 0;
  const seqLo = u32(bytes, 8), seqHi = u32(bytes, 12), refLo = u32(bytes, 16), refHi = u32(bytes, 20);
  const refValid = keyframe ? seqLo === refLo && seqHi === refHi
    : refHi < seqHi || (refHi === seqHi && refLo < seqLo);
  const seq = u64(bytes, 8), refSeq = u64(bytes, 16);
  if (!refValid) fail(`reference sequence ${refSeq} invalid for ${keyframe ? 'keyframe' : 'delta frame'} ${seq}`);
  const simTime = f64(bytes, 24), step = f64(bytes, 32), maxError = f32(bytes, 40);
  if (!Number.isFinite(simTime)) fail('sim time is not finite');
  if (!(maxError >= Math.fround(1e-5) && maxError <= Math.fround(0.1))) fail(`error bound ${maxError} m outside [1e-5, 0.1]`);
  if (!(step > 0 && step <= 2 * maxError)) fail(`quantization step ${step} m does not meet bound ${maxError} m`);
  const total = u32(bytes, 44), sent = u32(bytes, 48), nverts = u32(bytes, 52), stride = u32(bytes, 56);
  const payloadLen = u32(bytes, 60);
  if (nverts < 2 || nverts > MAX_NVERTS) fail(`${nverts} vertices per strand outside [2, ${MAX_NVERTS}]`);
  if (stride < 1 || total < 1) fail(`stride ${stride} / strand count ${total} must be positive`);
  const expect = Math.floor((total + stride - 1) / stride);
  if (sent !== expect) fail(`${sent} strands sent but ${total} strands at stride ${stride} give ${expect}`);
  if (sent * nverts > MAX_VERTICES) fail(`${sent} x ${nverts} vertices exceed the limit ${MAX_VERTICES}`);
  const frameLen = HEADER_SIZE + payloadLen;
  if (len !== frameLen) fail(`frame is ${len} bytes but its header says ${frameLen} (${len < frameLen ? 'truncated' : 'trailing bytes'})`);
  info.seq = seq; info.refSeq = refSeq; info.simTime = simTime; info.step = step; info.maxError = maxError;
  info.keyframe = keyframe; info.nstrandsTotal = total; info.nstrandsSent = sent; info.nverts = nverts;
  info.stride = stride; info.payloadLen = payloadLen; info.frameLen = frameLen;
  return info;
}

/**
 * Decodes a stream of strand frames. decode() returns a record (reused between calls) holding the
 * header fields and `positions`, a Float32Array (3 * nstrandsSent * nverts, strand-major xyz)
 * owned by the decoder and overwritten by the next successful decode. Bad frames throw an Error;
 * the decoder's state (the held keyframe) is then unchanged. Nothing is allocated per frame once
 * the first frame of a given size has been decoded.
 */
export class StrandDecoder {
  constructor() {
    this.info = newFrameInfo();
    this.info.positions = new Float32Array(0);
    this._hdr = newFrameInfo();
    this._key = newFrameInfo();
    this._keyValid = false;
    this._keyQ = new Int32Array(0);
    this._curQ = new Int32Array(0);
    this._freq = new Uint16Array(NTABLES * NSYM);
    this._start = new Uint16Array(NTABLES * NSYM);
    this._slots = new Uint16Array(NTABLES * SCALE);
    this._pos = 0; // table parser position
  }

  /** True when a keyframe is held (deltas against it can be decoded). */
  get hasKeyframe() { return this._keyValid; }

  /** Sequence number of the held keyframe (-1 when none). */
  get keySeq() { return this._keyValid ? this._key.seq : -1; }

  /** Forgets the held keyframe (e.g. after a reconnect). */
  reset() { this._keyValid = false; }

  /** Decodes one frame (a Uint8Array holding exactly the frame). */
  decode(bytes) {
    const h = peekHeader(bytes, this._hdr);
    const crc = u32(bytes, 64);
    let c = crc32(bytes, 0, 64, 0);
    c = crc32(bytes, HEADER_SIZE, bytes.length, c);
    if (c !== crc) fail(`CRC mismatch (frame ${h.seq} corrupted)`);
    if (!h.keyframe) {
      const k = this._key;
      if (!this._keyValid || k.seq !== h.refSeq) fail(`frame ${h.seq} needs keyframe ${h.refSeq}, which is not held`);
      if (k.nstrandsTotal !== h.nstrandsTotal || k.nverts !== h.nverts || k.stride !== h.stride || k.step !== h.step) {
        fail(`frame ${h.seq} does not match its keyframe's layout or step`);
      }
    }
    const nq = h.nstrandsSent * h.nverts * 3;
    if (this._curQ.length < nq) {
      const k = new Int32Array(nq);
      k.set(this._keyQ);
      this._keyQ = k;
      this._curQ = new Int32Array(nq);
    }
    const pl = HEADER_SIZE, end = bytes.length;
    this._pos = pl;
    this._readTables(bytes, end);
    let pos = this._pos;
    if (end - pos < 4) fail('truncated payload (no stream length)');
    const ransLen = u32(bytes, pos);
    pos += 4;
    if (ransLen < 8 || ransLen > end - pos) fail(`entropy stream length ${ransLen} invalid for ${end - pos} payload bytes left`);
    this._decodeStrands(bytes, h, pos, pos + ransLen, end);

    const out = this.info;
    if (out.positions.length !== nq) out.positions = new Float32Array(nq);
    const positions = out.positions, q = this._curQ, step = h.step;
    for (let i = 0; i < nq; i++) positions[i] = q[i] * step;
    if (h.keyframe) {
      const t = this._keyQ;
      this._keyQ = this._curQ;
      this._curQ = t;
      Object.assign(this._key, h);
      this._keyValid = true;
    }
    out.seq = h.seq; out.refSeq = h.refSeq; out.simTime = h.simTime; out.step = h.step; out.maxError = h.maxError;
    out.keyframe = h.keyframe; out.nstrandsTotal = h.nstrandsTotal; out.nstrandsSent = h.nstrandsSent;
    out.nverts = h.nverts; out.stride = h.stride; out.payloadLen = h.payloadLen; out.frameLen = h.frameLen;
    return out;
  }

  _varint(bytes, end) {
    let v = 0;
    for (let k = 0; k < 2; k++) {
      if (this._pos >= end) fail('truncated probability tables');
      const b = bytes[this._pos++];
      v |= (b & 0x7f) << (7 * k);
      if (!(b & 0x80)) return v;
    }
    return fail('oversized value in probability tables');
  }

  _readTables(bytes, end) {
    const freq = this._freq, start = this._start, slots = this._slots;
    for (let t = 0; t < NTABLES; t++) {
      const used = this._varint(bytes, end);
      if (used > NSYM) fail(`table ${t} lists ${used} symbols (max ${NSYM})`);
      const lut = t * SCALE;
      if (used === 0) {
        slots.fill(0xffff, lut, lut + SCALE);
        continue;
      }
      let st = 0, next = 0;
      for (let k = 0; k < used; k++) {
        const gap = this._varint(bytes, end);
        const f = this._varint(bytes, end);
        if (gap >= NSYM - next) fail(`table ${t} names a symbol beyond ${NSYM - 1}`);
        const s = next + gap;
        if (f === 0 || f > SCALE - st) fail(`table ${t} frequency ${f} invalid (sum must be ${SCALE})`);
        freq[t * NSYM + s] = f;
        start[t * NSYM + s] = st;
        slots.fill(s, lut + st, lut + st + f);
        st += f;
        next = s + 1;
      }
      if (st !== SCALE) fail(`table ${t} frequencies sum to ${st}, not ${SCALE}`);
    }
  }

  // Decodes all strands into this._curQ: rANS bytes [rpos, rend), raw bits [bstart, bend).
  _decodeStrands(bytes, h, rpos, rend, bend) {
    const freq = this._freq, start = this._start, slots = this._slots;
    const key = h.keyframe, nv = h.nverts, per = nv * 3, nmodes = key ? KEY_MODES : DELTA_MODES;
    const P = this._curQ, K = this._keyQ;
    const bstart = rend;
    let x0 = u32(bytes, rpos), x1 = u32(bytes, rpos + 4);
    rpos += 8;
    if (x0 < RANS_L || x0 >= RANS_L * 256 || x1 < RANS_L || x1 >= RANS_L * 256) fail('invalid entropy coder state');
    let which = 0;
    let bpos = bstart, acc = 0, nacc = 0;
    let r0 = 0, r1 = 0, r2 = 0;
    const badStream = 'corrupt entropy-coded data (invalid symbol or stream overrun)';

    for (let j = 0; j < h.nstrandsSent; j++) {
      const base = j * per, hasN = j > 0, nb = base - per;
      let mode = 0, table = T_MODE;
      // The mode symbol and then one symbol per vertex (root first).
      for (let v = -1; v < nv; v++) {
        // --- rANS symbol of `table`
        let x = which ? x1 : x0;
        const slot = x & (SCALE - 1);
        const s = slots[table * SCALE + slot];
        if (s === 0xffff) fail(badStream);
        const fi = table * NSYM + s;
        x = freq[fi] * (x >>> SCALE_BITS) + slot - start[fi];
        while (x < RANS_L) {
          if (rpos >= rend) fail(badStream);
          x = (x << 8) | bytes[rpos++];
        }
        if (which) x1 = x; else x0 = x;
        which ^= 1;
        if (v < 0) {
          if (s >= nmodes) fail(badStream);
          mode = s;
          table = T_ROOT;
          continue;
        }
        // --- residuals from the classes and raw bits
        const c0 = SYM_C0[s], c1 = SYM_C1[s], c2 = SYM_C2[s];
        const nbits = SYM_BITS[s];
        if (nbits >= 0) {
          while (nacc < nbits) {
            acc |= (bpos < bend ? bytes[bpos] : 0) << nacc;
            bpos++;
            nacc += 8;
          }
          let b = acc;
          acc >>>= nbits;
          nacc -= nbits;
          if (c0) { const m = (1 << (c0 - 1)) | ((b & ((1 << c0) - 1)) >>> 1); r0 = b & 1 ? -m : m; } else r0 = 0;
          b >>>= c0;
          if (c1) { const m = (1 << (c1 - 1)) | ((b & ((1 << c1) - 1)) >>> 1); r1 = b & 1 ? -m : m; } else r1 = 0;
          b >>>= c1;
          if (c2) { const m = (1 << (c2 - 1)) | ((b & ((1 << c2) - 1)) >>> 1); r2 = b & 1 ? -m : m; } else r2 = 0;
        } else {
          for (let a = 0; a < 3; a++) {
            const c = a === 0 ? c0 : a === 1 ? c1 : c2;
            let r = 0;
            if (c !== 0) {
              const n1 = c < ESCAPE ? c : 6;
              while (nacc < n1) { acc |= (bpos < bend ? bytes[bpos] : 0) << nacc; bpos++; nacc += 8; }
              let b = acc & ((1 << n1) - 1);
              acc >>>= n1;
              nacc -= n1;
              let m;
              if (c < ESCAPE) {
                m = (1 << (c - 1)) | (b >>> 1);
              } else {
                const ex = (b >>> 1) + 5;
                if (ex > 29) fail(badStream);
                // mantissa: up to 29 bits, read in two parts of at most 16
                let mant = 0, got = 0;
                while (got < ex) {
                  const n2 = ex - got > 16 ? 16 : ex - got;
                  while (nacc < n2) { acc |= (bpos < bend ? bytes[bpos] : 0) << nacc; bpos++; nacc += 8; }
                  mant += (acc & ((1 << n2) - 1)) * (1 << got);
                  acc >>>= n2;
                  nacc -= n2;
                  got += n2;
                }
                m = (1 << ex) + mant;
              }
              r = b & 1 ? -m : m;
            }
            if (a === 0) r0 = r; else if (a === 1) r1 = r; else r2 = r;
          }
        }
        table = v === 0 ? T_FIRST : SYM_NEXT[s];
        // --- prediction (codec_predict / codec_predict_root)
        const i = base + 3 * v;
        let p0, p1, p2;
        if (v === 0) {
          if (key) {
            if (hasN) { p0 = P[nb]; p1 = P[nb + 1]; p2 = P[nb + 2]; } else { p0 = 0; p1 = 0; p2 = 0; }
          } else if (hasN) {
            p0 = K[i] + P[nb] - K[nb]; p1 = K[i + 1] + P[nb + 1] - K[nb + 1]; p2 = K[i + 2] + P[nb + 2] - K[nb + 2];
          } else {
            p0 = K[i]; p1 = K[i + 1]; p2 = K[i + 2];
          }
        } else {
          const p = i - 3, pp = i - 6, n = i - per, np = p - per;
          let m = mode;
          if (key) {
            if (m === 1 && !hasN) m = 0;
            if (m === 2 && v < 3) m = 0;
            if (m === 1 || (v === 1 && hasN)) {
              p0 = P[p] + P[n] - P[np]; p1 = P[p + 1] + P[n + 1] - P[np + 1]; p2 = P[p + 2] + P[n + 2] - P[np + 2];
            } else if (v === 1) {
              p0 = P[p]; p1 = P[p + 1]; p2 = P[p + 2];
            } else if (m === 2) {
              p0 = 3 * P[p] - 3 * P[pp] + P[i - 9]; p1 = 3 * P[p + 1] - 3 * P[pp + 1] + P[i - 8];
              p2 = 3 * P[p + 2] - 3 * P[pp + 2] + P[i - 7];
            } else {
              p0 = 2 * P[p] - P[pp]; p1 = 2 * P[p + 1] - P[pp + 1]; p2 = 2 * P[p + 2] - P[pp + 2];
            }
          } else {
            if ((m === 1 || m === 2) && v === 1) m = 0;
            if (m === 3 && !hasN) m = 0;
            if (m === 0) {
              p0 = P[p] + K[i] - K[p]; p1 = P[p + 1] + K[i + 1] - K[p + 1]; p2 = P[p + 2] + K[i + 2] - K[p + 2];
            } else if (m === 1) {
              p0 = P[p] + K[i] - K[p] + (P[p] - K[p]) - (P[pp] - K[pp]);
              p1 = P[p + 1] + K[i + 1] - K[p + 1] + (P[p + 1] - K[p + 1]) - (P[pp + 1] - K[pp + 1]);
              p2 = P[p + 2] + K[i + 2] - K[p + 2] + (P[p + 2] - K[p + 2]) - (P[pp + 2] - K[pp + 2]);
            } else if (m === 2) {
              p0 = 2 * P[p] - P[pp]; p1 = 2 * P[p + 1] - P[pp + 1]; p2 = 2 * P[p + 2] - P[pp + 2];
            } else {
              p0 = P[p] + K[i] - K[p] + (P[n] - K[n]) - (P[np] - K[np]);
              p1 = P[p + 1] + K[i + 1] - K[p + 1] + (P[n + 1] - K[n + 1]) - (P[np + 1] - K[np + 1]);
              p2 = P[p + 2] + K[i + 2] - K[p + 2] + (P[n + 2] - K[n + 2]) - (P[np + 2] - K[np + 2]);
            }
          }
        }
        const q0 = p0 + r0, q1 = p1 + r1, q2 = p2 + r2;
        if (q0 <= -MAX_QUANT || q0 >= MAX_QUANT || q1 <= -MAX_QUANT || q1 >= MAX_QUANT ||
            q2 <= -MAX_QUANT || q2 >= MAX_QUANT) fail('corrupt frame (decoded coordinate out of range)');
        P[i] = q0; P[i + 1] = q1; P[i + 2] = q2;
      }
    }
    if (x0 !== RANS_L || x1 !== RANS_L || rpos !== rend) fail('entropy stream does not end where the frame says');
    const avail = (bend - bstart) * 8, used = (bpos - bstart) * 8 - nacc;
    if (used > avail || avail - used >= 8) fail(`raw bit stream is ${avail} bits, frame used ${used}`);
  }
}
