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
const T_ESC = T_BODY + NBODY;
const NESC = 25;
const NTABLES = T_ESC + 1;
const MAX_VERTICES = 1 << 24;
const MAX_NVERTS = 4096;
const MAX_QUANT = 1 << 26;
const MOTION_BYTES = 48;

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
    this._keyM = new Int32Array(0); // the keyframe moved by a delta's rigid motion
    this._motion = new Float64Array(12);
    this._slots = new Uint16Array(NTABLES * SCALE);  // slot -> symbol (0xffff: unused table)
    this._steps = new Uint32Array(NTABLES * SCALE);  // slot -> freq << 12 | (slot - start)
    this._res = new Int32Array(0); // residuals of one strand
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
      this._keyM = new Int32Array(nq);
    }
    const end = bytes.length;
    let pl = HEADER_SIZE;
    if (!h.keyframe) {
      if (end - pl < MOTION_BYTES) fail('truncated payload (no motion)');
      const m = this._motion;
      for (let k = 0; k < 12; k++) m[k] = f32(bytes, pl + 4 * k);
      for (let k = 0; k < 12; k++) {
        if (!(Math.abs(m[k]) <= (k < 9 ? 2 : 4 * MAX_QUANT))) fail('invalid rigid motion');
      }
      applyMotion(m, this._keyQ, this._keyM, nq / 3);
      pl += MOTION_BYTES;
    }
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
    dequantize(this._curQ, out.positions, nq, h.step);
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
    const slots = this._slots, steps = this._steps;
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
        slots.fill(s, lut + st, lut + st + f);
        for (let k = 0; k < f; k++) steps[lut + st + k] = (f << SCALE_BITS) | k;
        st += f;
        next = s + 1;
      }
      if (st !== SCALE) fail(`table ${t} frequencies sum to ${st}, not ${SCALE}`);
    }
  }

  // Decodes all strands into this._curQ: rANS bytes [rpos, rend), raw bits [bstart, bend).
  // Per strand: the mode and vertex symbols with their raw bits into residuals R, then the
  // predictions (one flat loop per mode).
  _decodeStrands(bytes, h, rpos, rend, bend) {
    const slots = this._slots, steps = this._steps;
    const key = h.keyframe, nv = h.nverts, per = nv * 3, nmodes = key ? KEY_MODES : DELTA_MODES;
    const P = this._curQ, K = this._keyM;
    if (this._res.length < per) this._res = new Int32Array(per);
    const R = this._res;
    const bstart = rend;
    let x0 = u32(bytes, rpos), x1 = u32(bytes, rpos + 4);
    rpos += 8;
    if (x0 < RANS_L || x0 >= RANS_L * 256 || x1 < RANS_L || x1 >= RANS_L * 256) fail('invalid entropy coder state');
    let bpos = bstart, acc = 0, nacc = 0;
    const badStream = 'corrupt entropy-coded data (invalid symbol or stream overrun)';

    for (let j = 0; j < h.nstrandsSent; j++) {
      const base = j * per;
      let mode = 0, table = T_MODE;
      for (let v = -1; v < nv; v++) {
        // rANS symbol of `table`; x0 is always the state of this symbol, x1 the next one's
        const li = (table << SCALE_BITS) + (x0 & (SCALE - 1));
        const s = slots[li], e = steps[li];
        if (s === 0xffff) fail(badStream);
        let x = (e >>> SCALE_BITS) * (x0 >>> SCALE_BITS) + (e & (SCALE - 1));
        while (x < RANS_L) {
          if (rpos >= rend) fail(badStream);
          x = (x << 8) | bytes[rpos++];
        }
        x0 = x1;
        x1 = x;
        if (v < 0) {
          if (s >= nmodes) fail(badStream);
          mode = s;
          table = T_ROOT;
          continue;
        }
        table = v === 0 ? T_FIRST : SYM_NEXT[s];
        const i = 3 * v;
        const nbits = SYM_BITS[s];
        if (nbits >= 0) {
          // fast path: the three fields, c0 + c1 + c2 <= 15 bits
          if (nacc < nbits) {
            if (bpos + 2 <= bend) acc |= (bytes[bpos] | (bytes[bpos + 1] << 8)) << nacc;
            else if (bpos < bend) acc |= bytes[bpos] << nacc;
            bpos += 2;
            nacc += 16;
          }
          let b = acc;
          acc >>>= nbits;
          nacc -= nbits;
          const c0 = SYM_C0[s], c1 = SYM_C1[s], c2 = SYM_C2[s];
          let f = b & ((1 << c0) - 1), m = ((1 << c0) >> 1) | (f >> 1), sg = f & 1;
          R[i] = (m ^ -sg) + sg;
          b >>>= c0;
          f = b & ((1 << c1) - 1); m = ((1 << c1) >> 1) | (f >> 1); sg = f & 1;
          R[i + 1] = (m ^ -sg) + sg;
          b >>>= c1;
          f = b & ((1 << c2) - 1); m = ((1 << c2) >> 1) | (f >> 1); sg = f & 1;
          R[i + 2] = (m ^ -sg) + sg;
          continue;
        }
        for (let a = 0; a < 3; a++) {
          const c = a === 0 ? SYM_C0[s] : a === 1 ? SYM_C1[s] : SYM_C2[s];
          if (c < ESCAPE) {
            while (nacc < c) { acc |= (bpos < bend ? bytes[bpos] : 0) << nacc; bpos++; nacc += 8; }
            const f = acc & ((1 << c) - 1);
            acc >>>= c;
            nacc -= c;
            const m = ((1 << c) >> 1) | (f >> 1);
            R[i + a] = f & 1 ? -m : m;
            continue;
          }
          // escape: e - 5 from the escape table (rANS), then sign and e mantissa bits (raw)
          const li = (T_ESC << SCALE_BITS) + (x0 & (SCALE - 1));
          const k = slots[li], ee = steps[li];
          if (k >= NESC) fail(badStream); // also an unused table (0xffff)
          let xe = (ee >>> SCALE_BITS) * (x0 >>> SCALE_BITS) + (ee & (SCALE - 1));
          while (xe < RANS_L) {
            if (rpos >= rend) fail(badStream);
            xe = (xe << 8) | bytes[rpos++];
          }
          x0 = x1;
          x1 = xe;
          const ex = k + 5;
          while (nacc < 1) { acc |= (bpos < bend ? bytes[bpos] : 0) << nacc; bpos++; nacc += 8; }
          const sign = acc & 1;
          acc >>>= 1;
          nacc -= 1;
          let mant = 0, got = 0; // up to 29 bits, read in parts of at most 16
          while (got < ex) {
            const n2 = ex - got > 16 ? 16 : ex - got;
            while (nacc < n2) { acc |= (bpos < bend ? bytes[bpos] : 0) << nacc; bpos++; nacc += 8; }
            mant += (acc & ((1 << n2) - 1)) * (1 << got);
            acc >>>= n2;
            nacc -= n2;
            got += n2;
          }
          const m = (1 << ex) + mant;
          R[i + a] = sign ? -m : m;
        }
      }
      if (!reconstruct(key, mode, P, K, base, per, R)) fail('corrupt frame (decoded coordinate out of range)');
    }
    if (x0 !== RANS_L || x1 !== RANS_L || rpos !== rend) fail('entropy stream does not end where the frame says');
    const avail = (bend - bstart) * 8, used = (bpos - bstart) * 8 - nacc;
    if (used > avail || avail - used >= 8) fail(`raw bit stream is ${avail} bits, frame used ${used}`);
  }
}

// out = round(R k + t) per vertex in binary64, clamped (codec_motion_apply): trunc of a sum
// that stays in (0, 2^31), so `| 0` is exact.
function applyMotion(m, k, out, nverts) {
  const lim = MAX_QUANT - 1, off = 1073741824;
  const r0 = m[0], r1 = m[1], r2 = m[2], r3 = m[3], r4 = m[4], r5 = m[5], r6 = m[6], r7 = m[7], r8 = m[8];
  const c0 = m[9] + 1073741824.5, c1 = m[10] + 1073741824.5, c2 = m[11] + 1073741824.5;
  for (let j = 0, n = nverts * 3; j < n; j += 3) {
    const x = k[j], y = k[j + 1], z = k[j + 2];
    let w = ((r0 * x + r1 * y + r2 * z + c0) | 0) - off;
    out[j] = w < -lim ? -lim : w > lim ? lim : w;
    w = ((r3 * x + r4 * y + r5 * z + c1) | 0) - off;
    out[j + 1] = w < -lim ? -lim : w > lim ? lim : w;
    w = ((r6 * x + r7 * y + r8 * z + c2) | 0) - off;
    out[j + 2] = w < -lim ? -lim : w > lim ? lim : w;
  }
}

// positions = float32(q * step), exactly as the C decoder.
function dequantize(q, positions, n, step) {
  for (let i = 0; i < n; i++) positions[i] = q[i] * step;
}

const inRange = (q) => q > -MAX_QUANT && q < MAX_QUANT;

// Rebuilds strand `base` (per = 3 * nverts coordinates) of P from residuals R with the
// predictions of proto/CODEC.md; K is the moved keyframe, the previous strand starts at
// base - per. One loop per prediction, the previous vertices carried in locals. Returns false
// on an out-of-range coordinate (|q| >= 2^26; values stay below 2^31 until the first one).
function reconstruct(key, mode, P, K, base, per, R) {
  const hasN = base > 0, end = base + per;
  // root
  for (let a = 0; a < 3; a++) {
    const i = base + a, n = i - per;
    const pred = key ? (hasN ? P[n] : 0) : (hasN ? K[i] + P[n] - K[n] : K[i]);
    const q = pred + R[a];
    if (!inRange(q)) return false;
    P[i] = q;
  }
  // vertex 1
  for (let a = 0; a < 3; a++) {
    const i = base + 3 + a, p = i - 3, n = i - per, np = p - per;
    let pred;
    if (key) pred = hasN ? P[p] + P[n] - P[np] : P[p];
    else pred = P[p] + K[i] - K[p];
    const q = pred + R[3 + a];
    if (!inRange(q)) return false;
    P[i] = q;
  }
  if (end - base <= 6) return true;
  const L = 67108863, L2 = 134217726; // |q| < 2^26  <=>  (q + L) >>> 0 <= L2
  let bad = 0, i = base + 6, r = 6;
  let a0 = P[i - 3], a1 = P[i - 2], a2 = P[i - 1]; // vertex v - 1
  let b0 = P[i - 6], b1 = P[i - 5], b2 = P[i - 4]; // vertex v - 2
  let q0, q1, q2;
  if (key && mode === 1 && hasN) { // the neighbour's segment
    for (; i < end; i += 3, r += 3) {
      const n = i - per;
      q0 = a0 + P[n] - P[n - 3] + R[r];
      q1 = a1 + P[n + 1] - P[n - 2] + R[r + 1];
      q2 = a2 + P[n + 2] - P[n - 1] + R[r + 2];
      bad |= (((q0 + L) >>> 0) > L2) | (((q1 + L) >>> 0) > L2) | (((q2 + L) >>> 0) > L2);
      P[i] = q0; P[i + 1] = q1; P[i + 2] = q2;
      a0 = q0; a1 = q1; a2 = q2;
    }
  } else if (key ? mode === 2 : mode === 3) { // smooth linear (linear at vertex 2)
    q0 = 2 * a0 - b0 + R[r]; q1 = 2 * a1 - b1 + R[r + 1]; q2 = 2 * a2 - b2 + R[r + 2];
    bad |= (((q0 + L) >>> 0) > L2) | (((q1 + L) >>> 0) > L2) | (((q2 + L) >>> 0) > L2);
    P[i] = q0; P[i + 1] = q1; P[i + 2] = q2;
    let c0 = b0, c1 = b1, c2 = b2;
    b0 = a0; b1 = a1; b2 = a2; a0 = q0; a1 = q1; a2 = q2;
    for (i += 3, r += 3; i < end; i += 3, r += 3) {
      // previous vertex + (a - c) / 2 rounded half to even (codec_smooth)
      let d = a0 - c0; q0 = a0 + ((d + ((d >> 1) & 1)) >> 1) + R[r];
      d = a1 - c1; q1 = a1 + ((d + ((d >> 1) & 1)) >> 1) + R[r + 1];
      d = a2 - c2; q2 = a2 + ((d + ((d >> 1) & 1)) >> 1) + R[r + 2];
      bad |= (((q0 + L) >>> 0) > L2) | (((q1 + L) >>> 0) > L2) | (((q2 + L) >>> 0) > L2);
      P[i] = q0; P[i + 1] = q1; P[i + 2] = q2;
      c0 = b0; c1 = b1; c2 = b2; b0 = a0; b1 = a1; b2 = a2; a0 = q0; a1 = q1; a2 = q2;
    }
  } else if (key || mode === 2) { // linear
    for (; i < end; i += 3, r += 3) {
      q0 = 2 * a0 - b0 + R[r]; q1 = 2 * a1 - b1 + R[r + 1]; q2 = 2 * a2 - b2 + R[r + 2];
      bad |= (((q0 + L) >>> 0) > L2) | (((q1 + L) >>> 0) > L2) | (((q2 + L) >>> 0) > L2);
      P[i] = q0; P[i + 1] = q1; P[i + 2] = q2;
      b0 = a0; b1 = a1; b2 = a2; a0 = q0; a1 = q1; a2 = q2;
    }
  } else if (mode === 1) { // the keyframe's segment plus the change of displacement
    let k0 = K[i - 3], k1 = K[i - 2], k2 = K[i - 1], l0 = K[i - 6], l1 = K[i - 5], l2 = K[i - 4];
    for (; i < end; i += 3, r += 3) {
      const n0 = K[i], n1 = K[i + 1], n2 = K[i + 2];
      q0 = a0 + n0 - k0 + (a0 - k0) - (b0 - l0) + R[r];
      q1 = a1 + n1 - k1 + (a1 - k1) - (b1 - l1) + R[r + 1];
      q2 = a2 + n2 - k2 + (a2 - k2) - (b2 - l2) + R[r + 2];
      bad |= (((q0 + L) >>> 0) > L2) | (((q1 + L) >>> 0) > L2) | (((q2 + L) >>> 0) > L2);
      P[i] = q0; P[i + 1] = q1; P[i + 2] = q2;
      b0 = a0; b1 = a1; b2 = a2; a0 = q0; a1 = q1; a2 = q2;
      l0 = k0; l1 = k1; l2 = k2; k0 = n0; k1 = n1; k2 = n2;
    }
  } else { // the keyframe's segment
    let k0 = K[i - 3], k1 = K[i - 2], k2 = K[i - 1];
    for (; i < end; i += 3, r += 3) {
      const n0 = K[i], n1 = K[i + 1], n2 = K[i + 2];
      q0 = a0 + n0 - k0 + R[r]; q1 = a1 + n1 - k1 + R[r + 1]; q2 = a2 + n2 - k2 + R[r + 2];
      bad |= (((q0 + L) >>> 0) > L2) | (((q1 + L) >>> 0) > L2) | (((q2 + L) >>> 0) > L2);
      P[i] = q0; P[i + 1] = q1; P[i + 2] = q2;
      a0 = q0; a1 = q1; a2 = q2; k0 = n0; k1 = n1; k2 = n2;
    }
  }
  return bad === 0;
}
