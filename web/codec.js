// Strand frame decoder (proto/CODEC.md), bit-exact with server/codec; browser, Worker or Node.

import {
  CodecKernel, kernelLayout, K_FREQ, K_INFO, K_RES, K_MOTION, K_STATE, K_BAD_STREAM, K_BAD_VALUE, INFO_SLOW,
  INFO_UNUSED,
} from './codec_kernel.js';

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
const NBODY = 6;
const T_MODE = 0;
const T_ROOT = 1;
const T_FIRST = 2;
const T_BODY = 3;
const T_ESC = T_BODY + NBODY;
const NTABLES = T_ESC + 1;
const MAX_VERTICES = 1 << 24;
const MAX_NVERTS = 4096;
const MAX_QUANT = 1 << 26;
const MOTION_BYTES = 48;
const BAD_STREAM = 'corrupt entropy-coded data (invalid symbol or stream overrun)';
const BAD_VALUE = 'corrupt frame (decoded coordinate out of range)';

// Per vertex symbol: its kernel INFO entry (codec_kernel.js) in a vertex table (1..8): the
// classes c0 | c1 << 3 | c2 << 6, the next vertex's body table << 9, INFO_SLOW when an axis
// is escaped. In the root table the next table is T_FIRST instead.
const SYM_INFO = new Uint16Array(NSYM);
for (let s = 0; s < NSYM; s++) {
  const c0 = s % NCLASS, c1 = Math.floor(s / NCLASS) % NCLASS, c2 = Math.floor(s / (NCLASS * NCLASS));
  const esc = c0 === ESCAPE || c1 === ESCAPE || c2 === ESCAPE;
  SYM_INFO[s] = c0 | (c1 << 3) | (c2 << 6) | ((T_BODY + Math.min(Math.max(c0, c1, c2), NBODY - 1)) << 9) |
    (esc ? INFO_SLOW : 0);
}

// CRC-32 (zlib polynomial), slicing by 8: CRC_TABLE[t * 256 + n] is the CRC of byte n followed
// by t zero bytes.
const CRC_TABLE = new Int32Array(256 * 8);
for (let n = 0; n < 256; n++) {
  let c = n;
  for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
  CRC_TABLE[n] = c;
}
for (let n = 0; n < 256; n++) {
  for (let t = 1; t < 8; t++) {
    const p = CRC_TABLE[(t - 1) * 256 + n];
    CRC_TABLE[t * 256 + n] = CRC_TABLE[p & 0xff] ^ (p >>> 8);
  }
}

/** zlib CRC-32 of bytes[from, to) (a Uint8Array), continuing from crc (0 to start). */
export function crc32(bytes, from, to, crc) {
  const mid = from + ((to - from) & ~7);
  return ~crcTail(bytes, mid, to, crcBlocks(bytes, from, mid, ~crc)) >>> 0;
}

// The CRC state c (inverted) after bytes[from, to), to - from a multiple of 8. A function of
// its own, apart from crcTail, so that nothing the compiler has not seen run follows its loop.
function crcBlocks(bytes, from, to, c) {
  const T = CRC_TABLE;
  for (let i = from; i < to; i += 8) {
    c ^= bytes[i] | (bytes[i + 1] << 8) | (bytes[i + 2] << 16) | (bytes[i + 3] << 24);
    const d = bytes[i + 4] | (bytes[i + 5] << 8) | (bytes[i + 6] << 16) | (bytes[i + 7] << 24);
    c = T[1792 + (c & 0xff)] ^ T[1536 + ((c >>> 8) & 0xff)] ^ T[1280 + ((c >>> 16) & 0xff)] ^ T[1024 + (c >>> 24)] ^
        T[768 + (d & 0xff)] ^ T[512 + ((d >>> 8) & 0xff)] ^ T[256 + ((d >>> 16) & 0xff)] ^ T[d >>> 24];
  }
  return c;
}

// The CRC state c (inverted) after bytes[from, to), one byte at a time.
function crcTail(bytes, from, to, c) {
  for (let i = from; i < to; i++) c = CRC_TABLE[(c ^ bytes[i]) & 0xff] ^ (c >>> 8);
  return c;
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
 * the decoder's state (the held keyframe) and `positions` are then unchanged. Nothing is
 * allocated per frame once a frame of the same size (or larger) has been decoded.
 */
export class StrandDecoder {
  constructor() {
    this.info = newFrameInfo();
    this.info.positions = new Float32Array(0);
    this._hdr = newFrameInfo();
    this._key = newFrameInfo();
    this._keyValid = false;
    // the kernel's heap (codec_kernel.js), grown to the largest frame seen
    this._heap = null;
    this._kernel = null;
    this._nqCap = 0;      // lattice coordinates its regions hold
    this._bytesCap = 0;   // frame bytes it holds
    this._keyOff = 0;     // the held keyframe's lattice (Int32)
    this._curOff = 0;     // the lattice being decoded (Int32)
    this._outOff = 0;     // positions being decoded (Float32)
    this._bytesOff = 0;   // the frame being decoded
    this._u8 = null;
    this._i32 = null;
    this._f64 = null;
    this._info16 = null;  // K_INFO
    this._freq32 = null;  // K_FREQ
    this._out = new Float32Array(0); // view of the output region, nq floats
  }

  /** True when a keyframe is held (deltas against it can be decoded). */
  get hasKeyframe() { return this._keyValid; }

  /** Sequence number of the held keyframe (-1 when none). */
  get keySeq() { return this._keyValid ? this._key.seq : -1; }

  /** Forgets the held keyframe (e.g. after a reconnect). */
  reset() { this._keyValid = false; }

  // Makes the heap hold nq coordinates and a frame of frameLen bytes, keeping the held keyframe.
  _reserve(nq, frameLen) {
    if (this._heap && nq <= this._nqCap && frameLen <= this._bytesCap) {
      if (this._out.length !== nq) this._out = new Float32Array(this._heap, this._outOff, nq);
      return;
    }
    const nqCap = Math.max(nq, this._nqCap);
    const bytesCap = Math.max(frameLen + (frameLen >> 2), this._bytesCap, 1 << 16);
    const lay = kernelLayout(nqCap, bytesCap);
    const heap = new ArrayBuffer(lay.size);
    const i32 = new Int32Array(heap);
    if (this._keyValid) {
      const kq = this._key.nstrandsSent * this._key.nverts * 3;
      i32.set(this._i32.subarray(this._keyOff >> 2, (this._keyOff >> 2) + kq), lay.key >> 2);
    }
    for (let c = 1; c < 6; c++) {
      for (let b = 0; b < 32; b++) {
        const f = b & ((1 << c) - 1), m = (1 << (c - 1)) | (f >> 1);
        i32[(K_RES >> 2) + ((c << 5) | b)] = f & 1 ? -m : m;
      }
    }
    this._heap = heap;
    this._kernel = CodecKernel(globalThis, null, heap);
    this._nqCap = nqCap;
    this._bytesCap = lay.size - lay.bytes;
    this._keyOff = lay.key;
    this._curOff = lay.cur;
    this._outOff = lay.out;
    this._bytesOff = lay.bytes;
    this._u8 = new Uint8Array(heap);
    this._i32 = i32;
    this._f64 = new Float64Array(heap);
    this._info16 = new Uint16Array(heap, K_INFO, NTABLES * SCALE);
    this._freq32 = new Int32Array(heap, K_FREQ, NTABLES * 512);
    this._out = new Float32Array(heap, lay.out, nq);
  }

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
    const nq = h.nstrandsSent * h.nverts * 3, end = bytes.length;
    this._reserve(nq, end);
    let pos = HEADER_SIZE;
    if (!h.keyframe) {
      if (end - pos < MOTION_BYTES) fail('truncated payload (no motion)');
      const m = this._f64, mo = K_MOTION >> 3;
      for (let k = 0; k < 12; k++) {
        const v = f32(bytes, pos + 4 * k);
        if (!(Math.abs(v) <= (k < 9 ? 2 : 4 * MAX_QUANT))) fail('invalid rigid motion');
        m[mo + k] = k < 9 ? v : v + 1073741824.5;
      }
      pos += MOTION_BYTES;
    }
    pos = readTables(bytes, pos, end, this._info16, this._freq32);
    if (end - pos < 4) fail('truncated payload (no stream length)');
    const ransLen = u32(bytes, pos);
    pos += 4;
    if (ransLen < 8 || ransLen > end - pos) fail(`entropy stream length ${ransLen} invalid for ${end - pos} payload bytes left`);
    const x0 = u32(bytes, pos), x1 = u32(bytes, pos + 4);
    if (x0 < RANS_L || x0 >= RANS_L * 256 || x1 < RANS_L || x1 >= RANS_L * 256) fail('invalid entropy coder state');
    const rend = pos + ransLen, b0 = this._bytesOff;
    this._u8.set(bytes, b0);
    const rc = this._kernel.frame(h.keyframe ? 1 : 0, h.nstrandsSent, 3 * h.nverts, x0, x1, b0 + pos + 8, b0 + rend,
      b0 + rend, b0 + end, this._keyOff, this._curOff, this._outOff, h.step);
    if (rc === K_BAD_STREAM) fail(BAD_STREAM);
    if (rc === K_BAD_VALUE) fail(BAD_VALUE);
    const st = this._i32, so = K_STATE >> 2;
    if (st[so] !== RANS_L || st[so + 1] !== RANS_L || st[so + 2] !== b0 + rend) fail('entropy stream does not end where the frame says');
    const avail = (end - rend) * 8, used = st[so + 3];
    if (used > avail || avail - used >= 8) fail(`raw bit stream is ${avail} bits, frame used ${used}`);

    const info = this.info;
    if (info.positions.length !== nq) info.positions = new Float32Array(nq);
    info.positions.set(this._out);
    if (h.keyframe) {
      const t = this._keyOff;
      this._keyOff = this._curOff;
      this._curOff = t;
      Object.assign(this._key, h);
      this._keyValid = true;
    }
    info.seq = h.seq; info.refSeq = h.refSeq; info.simTime = h.simTime; info.step = h.step; info.maxError = h.maxError;
    info.keyframe = h.keyframe; info.nstrandsTotal = h.nstrandsTotal; info.nstrandsSent = h.nstrandsSent;
    info.nverts = h.nverts; info.stride = h.stride; info.payloadLen = h.payloadLen; info.frameLen = h.frameLen;
    return info;
  }
}

// LEB128 value of at most 2 bytes at bytes[pos] (pos < end checked); returns value << 16 | bytes.
function varint(bytes, pos, end) {
  if (pos >= end) fail('truncated probability tables');
  const b0 = bytes[pos];
  if (!(b0 & 0x80)) return (b0 << 16) | 1;
  if (pos + 1 >= end) fail('truncated probability tables');
  const b1 = bytes[pos + 1];
  if (b1 & 0x80) fail('oversized value in probability tables');
  return (((b0 & 0x7f) | (b1 << 7)) << 16) | 2;
}

// Reads the ten probability tables at bytes[pos, end) into the kernel's lookups
// (codec_kernel.js): info, per table and slot, the INFO entry of the symbol whose
// [start, start + freq) holds the slot; freq, per table and symbol key, freq << 12 | start.
// Returns the position after them.
function readTables(bytes, pos, end, info, freq) {
  for (let t = 0; t < NTABLES; t++) {
    let vb = varint(bytes, pos, end);
    pos += vb & 3;
    const used = vb >> 16;
    if (used > NSYM) fail(`table ${t} lists ${used} symbols (max ${NSYM})`);
    const lut = t * SCALE;
    if (used === 0) {
      info.fill(INFO_UNUSED, lut, lut + SCALE);
      continue;
    }
    let st = 0, next = 0;
    for (let k = 0; k < used; k++) {
      vb = varint(bytes, pos, end);
      pos += vb & 3;
      const gap = vb >> 16;
      vb = varint(bytes, pos, end);
      pos += vb & 3;
      const f = vb >> 16;
      if (gap >= NSYM - next) fail(`table ${t} names a symbol beyond ${NSYM - 1}`);
      const s = next + gap;
      if (f === 0 || f > SCALE - st) fail(`table ${t} frequency ${f} invalid (sum must be ${SCALE})`);
      const from = lut + st, to = from + f;
      const v = t === T_MODE || t === T_ESC ? s : t === T_ROOT ? (SYM_INFO[s] & ~(15 << 9)) | (T_FIRST << 9) : SYM_INFO[s];
      info.fill(v, from, to);
      freq[(t << 9) | (v & 511)] = (f << SCALE_BITS) | st;
      st += f;
      next = s + 1;
    }
    if (st !== SCALE) fail(`table ${t} frequencies sum to ${st}, not ${SCALE}`);
  }
  return pos;
}
