// Strand frame decoder (proto/CODEC.md), bit-exact with server/codec; browser, Worker or Node.

import { KERNEL_WASM } from './codec_kernel_wasm.js';

export const HEADER_SIZE = 68;
export const FORMAT_VERSION = 2;
export const CODEC_ID_STRAND = 1;
export const FLAG_KEY = 1;

const MAGIC = [0x53, 0x43, 0x46, 0x31]; // "SCF1"
const SCALE_BITS = 12;
const SCALE = 1 << SCALE_BITS;
const RANS_L = 1 << 16;
const LANES = 8;
const NCLASS = 7;
const ESCAPE = 6;
const NSYM = NCLASS * NCLASS * NCLASS;
const NBODY = 6;
const T_MODE = 0;
const T_ROOT = 1;
const T_FIRST = 2;
const T_BODY = 3;
const NTABLES = T_BODY + NBODY;
const MAX_VERTICES = 1 << 24;
const MAX_NVERTS = 4096;
const MOTION_BYTES = 48;
const ROT_ONE = 1 << 14;
const MAX_SHIFT = 1 << 28;

// The WebAssembly kernel (web/wasm/codec_kernel.c): compiled once, on first use, synchronously
// (workers and Node allow that for a module this small); one instance per memory.
let kernelModule = null;
function kernelInstance(memory) {
  if (!kernelModule) {
    const text = atob(KERNEL_WASM);
    const bytes = new Uint8Array(text.length);
    for (let i = 0; i < text.length; i++) bytes[i] = text.charCodeAt(i);
    try {
      kernelModule = new WebAssembly.Module(bytes);
    } catch (e) {
      fail(`this engine cannot compile the WebAssembly SIMD decode kernel (${e.message})`);
    }
  }
  return new WebAssembly.Instance(kernelModule, { env: { memory } }).exports;
}

// Kernel result codes (codec_kernel.c).
const K_BAD_SYMBOL = -1, K_BAD_MODE = -2, K_OVERRUN = -3, K_BAD_ESCAPE = -4, K_BAD_VALUE = -5;
const K_BITS_SHORT = -6, K_BAD_END = -7, K_BITS_LEFT = -8;
// INFO entries (codec_kernel.c, kern.info): an escaped axis; every slot of an unused table (an
// escape, next table T_IDLE, classes no vertex symbol has).
const INFO_SLOW = 1 << 9;
const INFO_UNUSED = 0x9fff;
// Where the kernel's state (struct kern) lies in its memory: above the module's own stack
// (build.sh: 64 KiB, first).
export const KERN_BASE = 65536;
// Bytes after a frame that a corrupt frame's group may read before the kernel refuses it (at
// most 120 per vertex of a strand, plus 64).
const READ_SLACK = 1 << 19;

/**
 * Byte offsets, in the kernel's memory, of the regions for frames of nq lattice coordinates (of
 * strands of at most 4096 vertices) whose bytes need frameCap bytes, after the kernel's state of
 * kernSize bytes: the held keyframe's and the current frame's lattice (Int32), two outputs
 * (Float32), the held keyframe's and the current frame's clamped segments (Int16, 4 per vertex,
 * in groups of 8 strands, padded), the frame's bytes (READ_SLACK readable bytes after them),
 * and the memory's size in 64 KiB pages.
 */
export function kernelLayout(nq, frameCap, kernSize) {
  const key = (KERN_BASE + kernSize + 15) & ~15, cur = key + 4 * nq, out = cur + 4 * nq, out2 = out + 4 * nq;
  const seg = ((8 * nq) / 3 + 8 * 7 * 4096 + 15) & ~15;
  const dkey = out2 + 4 * nq, dcur = dkey + seg, bytes = dcur + seg;
  const pages = Math.ceil((bytes + frameCap + 16 + READ_SLACK) / 65536);
  return { key, cur, out, out2, dkey, dcur, bytes, pages };
}

// Per vertex symbol: its kernel INFO entry (codec_kernel.c) in a vertex table (1..8): the
// classes c0 | c1 << 3 | c2 << 6, INFO_SLOW when an axis is escaped, the next vertex's body
// table << 12. In the root table the next table is T_FIRST instead.
const SYM_INFO = new Uint16Array(NSYM);
for (let s = 0; s < NSYM; s++) {
  const c0 = s % NCLASS, c1 = Math.floor(s / NCLASS) % NCLASS, c2 = Math.floor(s / (NCLASS * NCLASS));
  const esc = c0 === ESCAPE || c1 === ESCAPE || c2 === ESCAPE;
  SYM_INFO[s] = c0 | (c1 << 3) | (c2 << 6) | (esc ? INFO_SLOW : 0) |
    ((T_BODY + Math.min(Math.max(c0, c1, c2), NBODY - 1)) << 12);
}

// The kernel's error codes, as messages.
const KERNEL_ERRORS = new Map([
  [K_BAD_SYMBOL, 'corrupt entropy-coded data (a symbol from an unused probability table)'],
  [K_BAD_MODE, 'corrupt entropy-coded data (prediction mode out of range)'],
  [K_OVERRUN, 'corrupt entropy-coded data (rANS stream overrun)'],
  [K_BAD_ESCAPE, 'corrupt raw bits (escape exponent above 24)'],
  [K_BAD_VALUE, 'corrupt frame (decoded coordinate out of range)'],
  [K_BITS_SHORT, 'corrupt raw bits (raw bit stream overrun)'],
  [K_BAD_END, 'entropy stream does not end in the initial states with every word read'],
  [K_BITS_LEFT, 'raw bit stream is longer than the frame uses'],
]);

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
 * owned by the decoder. Successive successful decodes return two such arrays in turn (the
 * decoder writes a frame where the previous frame's positions are not, so that a bad frame
 * leaves them as they were, without copying them): `positions` stays valid until the next
 * successful decode but one, which overwrites it. Bad frames throw an Error; the decoder's state
 * (the held keyframe) and `positions` are then unchanged. Nothing is allocated per frame once a
 * frame of the same size (or larger) has been decoded.
 */
export class StrandDecoder {
  constructor() {
    this.info = newFrameInfo();
    this.info.positions = new Float32Array(0);
    this._hdr = newFrameInfo();
    this._key = newFrameInfo();
    this._keyValid = false;
    // the kernel's memory (codec_kernel.c), grown to the largest frame seen, and its instance
    this._memory = null;
    this._kernel = null;
    this._kernSize = 0;   // its state's size (struct kern)
    this._state = 0;      // its lane states (Int32 index)
    this._motion = 0;     // its motion (Int32 index)
    this._list = 0;       // its table list (Int32 index)
    this._nqCap = 0;      // lattice coordinates its regions hold
    this._bytesCap = 0;   // frame bytes it holds
    this._keyOff = 0;     // the held keyframe's lattice (Int32)
    this._curOff = 0;     // the lattice being decoded (Int32)
    this._dkeyOff = 0;    // the held keyframe's clamped segments (Int16)
    this._dcurOff = 0;    // the clamped segments of the keyframe being decoded (Int16)
    this._segBytes = 0;   // the bytes of a clamped segments region
    this._outOffs = [0, 0]; // the two output regions (Float32): positions alternate between them
    this._outViews = [null, null]; // their Float32Array views as returned
    this._next = 0;       // the output region the next frame is decoded into
    this._bytesOff = 0;   // the frame being decoded
    this._u8 = null;
    this._i32 = null;
  }

  /** True when a keyframe is held (deltas against it can be decoded). */
  get hasKeyframe() { return this._keyValid; }

  /** Sequence number of the held keyframe (-1 when none). */
  get keySeq() { return this._keyValid ? this._key.seq : -1; }

  /** Forgets the held keyframe (e.g. after a reconnect). */
  reset() { this._keyValid = false; }

  // Makes the kernel's memory hold nq coordinates and a frame of frameLen bytes, keeping the held
  // keyframe (a new memory and instance when it grows).
  _reserve(nq, frameLen) {
    if (this._memory && nq <= this._nqCap && frameLen <= this._bytesCap) {
      return;
    }
    const nqCap = Math.max(nq, this._nqCap);
    const bytesCap = Math.max(frameLen + (frameLen >> 2), this._bytesCap, 1 << 16);
    let kernSize = this._kernSize;
    if (!kernSize) {
      kernSize = kernelInstance(new WebAssembly.Memory({ initial: 2 })).kern_offset(3);
    }
    const lay = kernelLayout(nqCap, bytesCap, kernSize);
    const memory = new WebAssembly.Memory({ initial: lay.pages });
    const kernel = kernelInstance(memory);
    const heap = memory.buffer;
    if (this._keyValid) {
      const kq = this._key.nstrandsSent * this._key.nverts * 3;
      new Int32Array(heap, lay.key, kq).set(new Int32Array(this._memory.buffer, this._keyOff, kq));
      new Uint8Array(heap, lay.dkey, this._segBytes).set(new Uint8Array(this._memory.buffer, this._dkeyOff, this._segBytes));
    }
    kernel.kern_init(KERN_BASE);
    this._memory = memory;
    this._kernel = kernel;
    this._kernSize = kernSize;
    this._state = (KERN_BASE + kernel.kern_offset(1)) >> 2;
    this._motion = (KERN_BASE + kernel.kern_offset(2)) >> 2;
    this._list = (KERN_BASE + kernel.kern_offset(0)) >> 2;
    this._nqCap = nqCap;
    this._bytesCap = bytesCap;
    this._keyOff = lay.key;
    this._curOff = lay.cur;
    this._dkeyOff = lay.dkey;
    this._dcurOff = lay.dcur;
    this._segBytes = lay.dcur - lay.dkey;
    this._outOffs = [lay.out, lay.out2];
    this._outViews = [null, null];
    this._bytesOff = lay.bytes;
    this._u8 = new Uint8Array(heap);
    this._i32 = new Int32Array(heap);
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
      readMotion(bytes, pos, this._i32, this._motion);
      pos += MOTION_BYTES;
    }
    pos = readTables(bytes, pos, end, this._i32, this._list, this._kernel);
    if (end - pos < 4) fail('truncated payload (no stream length)');
    const ransLen = u32(bytes, pos);
    pos += 4;
    if (ransLen < 4 * LANES || ransLen % 2 !== 0 || ransLen > end - pos) {
      fail(`entropy stream length ${ransLen} invalid (even, at least ${4 * LANES}, at most the ${end - pos} payload bytes left)`);
    }
    const lane = this._state;
    for (let l = 0; l < LANES; l++) {
      const x = u32(bytes, pos + 4 * l);
      if (x < RANS_L) fail(`invalid entropy coder state ${x} in lane ${l} (below 2^16)`);
      this._i32[lane + l] = x | 0;
    }
    const rend = pos + ransLen, avail = (end - rend) * 8;
    if (avail > 0x7fffffff) fail(`raw bit stream of ${avail} bits is longer than any frame uses`);
    // the frame goes to the kernel's memory, zeros after it
    const b0 = this._bytesOff;
    this._u8.set(bytes, b0);
    this._u8.fill(0, b0 + end, b0 + end + 16);
    const rc = this._kernel.kern_frame(KERN_BASE, h.keyframe ? 1 : 0, h.nstrandsSent, h.nverts, b0 + pos + 4 * LANES,
      b0 + rend, b0 + rend, avail, this._keyOff, this._curOff, this._outOffs[this._next], this._dkeyOff, this._dcurOff,
      h.step);
    if (rc !== 0) {
      const used = this._i32[this._state + 9] >>> 0;
      if (rc === K_BITS_SHORT || rc === K_BITS_LEFT) fail(`raw bit stream is ${avail} bits, frame used ${used}`);
      fail(KERNEL_ERRORS.get(rc) ?? `kernel error ${rc}`);
    }

    const info = this.info;
    const k = this._next, view = this._outViews[k];
    info.positions = view && view.length === nq ? view : (this._outViews[k] = new Float32Array(this._memory.buffer, this._outOffs[k], nq));
    this._next = k ^ 1;
    if (h.keyframe) {
      let t = this._keyOff;
      this._keyOff = this._curOff;
      this._curOff = t;
      t = this._dkeyOff;
      this._dkeyOff = this._dcurOff;
      this._dcurOff = t;
      Object.assign(this._key, h);
      this._keyValid = true;
    }
    info.seq = h.seq; info.refSeq = h.refSeq; info.simTime = h.simTime; info.step = h.step; info.maxError = h.maxError;
    info.keyframe = h.keyframe; info.nstrandsTotal = h.nstrandsTotal; info.nstrandsSent = h.nstrandsSent;
    info.nverts = h.nverts; info.stride = h.stride; info.payloadLen = h.payloadLen; info.frameLen = h.frameLen;
    return info;
  }
}

// Reads and checks a delta's rigid motion at bytes[pos, pos + 48) into the kernel's motion at
// i32[mo] (rho_0..rho_8, then t_0..t_2).
function readMotion(bytes, pos, i32, mo) {
  for (let k = 0; k < 9; k++) {
    const r = (u16(bytes, pos + 2 * k) << 16) >> 16;
    if (r < -ROT_ONE || r > ROT_ONE) fail(`invalid rigid motion (rotation entry ${k} is ${r}, outside [-16384, 16384])`);
    i32[mo + k] = r;
  }
  for (let k = 0; k < 3; k++) {
    const t = u32(bytes, pos + 20 + 4 * k) | 0;
    if (t < -MAX_SHIFT || t > MAX_SHIFT) fail(`invalid rigid motion (translation ${k} is ${t}, outside [-2^28, 2^28])`);
    i32[mo + 9 + k] = t;
  }
  for (const k of [18, 19, 32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, 43, 44, 45, 46, 47]) {
    if (bytes[pos + k] !== 0) fail(`invalid rigid motion (padding byte ${k} is not zero)`);
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

// Reads the nine probability tables at bytes[pos, end) and has the kernel build its per-slot
// lookups from them (codec_kernel.c, kern_tables(): a list at i32[list] of entries
// table << 16 | INFO entry, freq << 12 | start). Returns the position after them.
function readTables(bytes, pos, end, i32, list, kernel) {
  let li = list;
  for (let t = 0; t < NTABLES; t++) {
    let vb = varint(bytes, pos, end);
    pos += vb & 3;
    const used = vb >> 16;
    if (used > NSYM) fail(`table ${t} lists ${used} symbols (max ${NSYM})`);
    if (used === 0) {
      i32[li++] = (t << 16) | INFO_UNUSED;
      i32[li++] = SCALE << SCALE_BITS;
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
      const v = t === T_MODE ? s : t === T_ROOT ? (SYM_INFO[s] & ~(15 << 12)) | (T_FIRST << 12) : SYM_INFO[s];
      i32[li++] = (t << 16) | v;
      i32[li++] = (f << SCALE_BITS) | st;
      st += f;
      next = s + 1;
    }
    if (st !== SCALE) fail(`table ${t} frequencies sum to ${st}, not ${SCALE}`);
  }
  kernel.kern_tables(KERN_BASE, (li - list) >> 1);
  return pos;
}
