// Strand and hair mesh frame decoder (proto/CODEC.md); browser, Worker or Node. The decoding is the decode core
// of the daemon (server/codec/codec_core.c, compiled to WebAssembly by web/wasm/build.sh): this
// module loads it, gives it memory and turns its failures into messages.

import { KERNEL_WASM } from './codec_kernel_wasm.js';

export const HEADER_SIZE = 104;
export const FORMAT_VERSION = 3;
export const CODEC_ID_STRAND = 1;
// A hair mesh's vertices: its columns as strands of nlayers vertices (nverts), stride 1.
export const CODEC_ID_HAIRMESH = 2;
export const FLAG_KEY = 1;

// Readable bytes a frame needs after it in the core's memory (CODEC_CORE_SLACK).
export const READ_SLACK = 1 << 19;
// The core's state (struct codec_core): its header record, the held keyframe's, its last failure
// (struct codec_core_error) and whether a keyframe is held, at these offsets.
const INFO = 0, KEY = 104, ERROR = 208, KEY_VALID = 240, KEY_SLOT = 244;
const INFO_SIZE = 104, ERROR_SIZE = 32;
// A head rotation is a unit quaternion within this (CODEC_HEAD_NORM_TOL): |x²+y²+z²+w² - 1|.
const HEAD_NORM_TOL = 1e-4;
const PAGE = 65536;

// The core's failures (enum codec_core_code), in order from 1.
const E = Object.freeze({
  SHORT_HEADER: 1, MAGIC: 2, VERSION: 3, CODEC: 4, FLAGS: 5, REF: 6, TIME: 7, HEAD: 8, BOUND: 9, STEP: 10,
  NVERTS: 11, COUNTS: 12, SENT: 13, TOO_MANY: 14, LENGTH: 15, CRC: 16, NO_KEY: 17, KEY_LAYOUT: 18,
  NO_MOTION: 19, ROTATION: 20, TRANSLATION: 21, PADDING: 22, TABLE_SHORT: 23, TABLE_VARINT: 24,
  TABLE_COUNT: 25, TABLE_SYMBOL: 26, TABLE_FREQ: 27, TABLE_SUM: 28, NO_STREAM: 29, STREAM_LEN: 30, STATE: 31,
  SYMBOL: 32, MODE: 33, OVERRUN: 34, ESCAPE: 35, VALUE: 36, BITS: 37, END: 38,
});

// The header field each failure is about (the table, strand and motion ones say it themselves).
const FIELDS = new Map([
  [E.SHORT_HEADER, 'header'], [E.MAGIC, 'magic'], [E.VERSION, 'version'], [E.CODEC, 'codec'], [E.FLAGS, 'flags'],
  [E.REF, 'ref_seq'], [E.TIME, 'sim_time'], [E.HEAD, 'head'], [E.BOUND, 'max_error_m'], [E.STEP, 'step'], [E.NVERTS, 'nverts'],
  [E.COUNTS, 'stride / nstrands_total'], [E.SENT, 'nstrands_sent'], [E.TOO_MANY, 'nstrands_sent'],
  [E.LENGTH, 'payload_len'], [E.CRC, 'crc32'], [E.NO_KEY, 'ref_seq'], [E.KEY_LAYOUT, 'step'],
  [E.NO_MOTION, 'motion'], [E.ROTATION, 'motion'], [E.TRANSLATION, 'motion'], [E.PADDING, 'motion'],
  [E.NO_STREAM, 'rans_len'], [E.STREAM_LEN, 'rans_len'], [E.STATE, 'rans states'], [E.BITS, 'raw bits'],
  [E.END, 'rans'],
]);

// The messages, as server/codec/codec_decode.c words them: (h header record, e failure, len
// frame length) -> text.
const MESSAGES = new Map([
  [E.SHORT_HEADER, (h, e, len) => `truncated header (${len} bytes, need ${HEADER_SIZE})`],
  [E.MAGIC, () => 'bad magic (not a strand frame)'],
  [E.VERSION, (h, e) => `unsupported format version ${e.a} (this decoder reads ${FORMAT_VERSION})`],
  [E.CODEC, (h, e) => `unknown codec id ${e.a}`],
  [E.FLAGS, (h, e) => `unknown flags 0x${e.a.toString(16).padStart(2, '0')}`],
  [E.REF, (h) => `reference sequence ${h.refSeq} invalid for ${h.keyframe ? 'keyframe' : 'delta frame'} ${h.seq}`],
  [E.TIME, () => 'sim time is not finite'],
  [E.HEAD, (h, e) => (e.index === 2
    ? `head rotation is not a unit quaternion (squared norm ${g9(e.norm2)}, not within ${HEAD_NORM_TOL} of 1)`
    : `head ${e.index ? 'rotation' : 'position'} is not finite`)],
  [E.BOUND, (h) => `error bound ${h.maxError} m outside [1e-5, 0.1]`],
  [E.STEP, (h) => `quantization step ${h.step} m does not meet bound ${h.maxError} m`],
  [E.NVERTS, (h) => `${h.nverts} vertices per strand outside [2, 4096]`],
  [E.COUNTS, (h) => (h.codec === CODEC_ID_HAIRMESH && h.stride >= 1 && h.nstrandsTotal >= 1
    ? `a hair mesh frame has stride 1, not ${h.stride}`
    : `stride ${h.stride} / strand count ${h.nstrandsTotal} must be positive`)],
  [E.SENT, (h, e) => `${h.nstrandsSent} strands sent but ${h.nstrandsTotal} strands at stride ${h.stride} give ${e.a}`],
  [E.TOO_MANY, (h) => `${h.nstrandsSent} x ${h.nverts} vertices exceed the limit ${1 << 24}`],
  [E.LENGTH, (h, e, len) => `frame is ${len} bytes but its header says ${HEADER_SIZE + h.payloadLen} (${len < HEADER_SIZE + h.payloadLen ? 'truncated' : 'trailing bytes'})`],
  [E.CRC, (h) => `CRC mismatch (frame ${h.seq} corrupted)`],
  [E.NO_KEY, (h) => `frame ${h.seq} needs keyframe ${h.refSeq}, which is not held`],
  [E.KEY_LAYOUT, (h) => `frame ${h.seq} does not match its keyframe's layout or step`],
  [E.NO_MOTION, () => 'truncated payload (no motion)'],
  [E.ROTATION, (h, e) => `invalid rigid motion (rotation entry ${e.index} is ${e.signedA}, outside [-16384, 16384])`],
  [E.TRANSLATION, (h, e) => `invalid rigid motion (translation ${e.index} is ${e.signedA}, outside [-2^28, 2^28])`],
  [E.PADDING, (h, e) => `invalid rigid motion (padding byte ${e.index} is not zero)`],
  [E.TABLE_SHORT, () => 'truncated probability tables'],
  [E.TABLE_VARINT, () => 'oversized value in probability tables'],
  [E.TABLE_COUNT, (h, e) => `table ${e.index} lists ${e.a} symbols (max 343)`],
  [E.TABLE_SYMBOL, (h, e) => `table ${e.index} names a symbol beyond 342`],
  [E.TABLE_FREQ, (h, e) => `table ${e.index} frequency ${e.a} invalid (sum must be 4096)`],
  [E.TABLE_SUM, (h, e) => `table ${e.index} frequencies sum to ${e.a}, not 4096`],
  [E.NO_STREAM, () => 'truncated payload (no stream length)'],
  [E.STREAM_LEN, (h, e) => `entropy stream length ${e.a} invalid (even, at least 32, at most the ${e.b} payload bytes left)`],
  [E.STATE, (h, e) => `invalid entropy coder state ${e.a} in lane ${e.index} (below 2^16)`],
  [E.SYMBOL, () => 'corrupt entropy-coded data (a symbol from an unused probability table)'],
  [E.MODE, () => 'corrupt entropy-coded data (prediction mode out of range)'],
  [E.OVERRUN, () => 'corrupt entropy-coded data (rANS stream overrun)'],
  [E.ESCAPE, () => 'corrupt raw bits (escape exponent above 24)'],
  [E.VALUE, () => 'corrupt frame (decoded coordinate out of range)'],
  [E.BITS, (h, e) => `raw bit stream is ${e.a} bits, frame used ${e.b}`],
  [E.END, () => 'entropy stream does not end in the initial states with every word read'],
]);

const fail = (msg) => { throw new Error('codec: ' + msg); };

// x as C's printf("%.9g") writes it (finite x).
function g9(x) {
  const exp = Number(x.toExponential(8).split('e')[1]);
  const strip = (s) => (s.includes('.') ? s.replace(/\.?0+$/, '') : s);
  if (exp < -4 || exp >= 9) {
    const [m, e] = x.toExponential(8).split('e');
    return `${strip(m)}e${e[0] === '-' ? '-' : '+'}${e.replace(/^[-+]/, '').padStart(2, '0')}`;
  }
  return strip(x.toFixed(8 - exp));
}

// The module, compiled once, on first use, synchronously (workers and Node allow that for a module
// this small); one instance per memory.
let coreModule = null;
function instantiate(memory) {
  if (!coreModule) {
    const text = atob(KERNEL_WASM);
    const bytes = new Uint8Array(text.length);
    for (let i = 0; i < text.length; i++) bytes[i] = text.charCodeAt(i);
    try {
      coreModule = new WebAssembly.Module(bytes);
    } catch (e) {
      fail(`this engine cannot compile the WebAssembly SIMD decode core (${e.message})`);
    }
  }
  return new WebAssembly.Instance(coreModule, { env: { memory } }).exports;
}

/**
 * A core in a memory of its own: `base` its state (struct codec_core), `heap` the first byte after
 * it. Grown by grow(bytes) (the views are made again); used as is by peekHeader and crc32.
 */
class CoreMemory {
  constructor(extra) {
    const probe = instantiate(new WebAssembly.Memory({ initial: 2 }));
    this.base = (probe.__heap_base.value + 63) & ~63;
    this.heap = (this.base + probe.codec_core_size() + 63) & ~63;
    this.memory = new WebAssembly.Memory({ initial: Math.ceil((this.heap + extra) / PAGE) });
    this.x = instantiate(this.memory);
    this.x.codec_core_init(this.base);
    this._views();
  }

  // Makes the memory hold at least bytes bytes past heap.
  grow(bytes) {
    const need = Math.ceil((this.heap + bytes) / PAGE) - this.memory.buffer.byteLength / PAGE;
    if (need > 0) {
      this.memory.grow(need);
      this._views();
    }
  }

  _views() {
    this.u8 = new Uint8Array(this.memory.buffer);
    this.dv = new DataView(this.memory.buffer);
  }
}

// The core that peekHeader and crc32 use, made on first use.
let scratch = null;
function scratchCore(bytes) {
  if (!scratch) scratch = new CoreMemory(PAGE);
  scratch.grow(bytes);
  return scratch;
}

function u64(dv, at) { return dv.getUint32(at, true) + dv.getUint32(at + 4, true) * 4294967296; } // exact below 2^53

// The header record at dv[at] (struct codec_core_info) into info.
function readInfo(dv, at, info) {
  info.seq = u64(dv, at); info.refSeq = u64(dv, at + 8); info.simTime = dv.getFloat64(at + 16, true);
  info.step = dv.getFloat64(at + 24, true); info.maxError = dv.getFloat32(at + 32, true);
  info.keyframe = dv.getUint32(at + 36, true) !== 0; info.nstrandsTotal = dv.getUint32(at + 40, true);
  info.nstrandsSent = dv.getUint32(at + 44, true); info.nverts = dv.getUint32(at + 48, true);
  info.stride = dv.getUint32(at + 52, true); info.payloadLen = dv.getUint32(at + 56, true);
  info.codec = dv.getUint32(at + 60, true);
  info.frameLen = HEADER_SIZE + info.payloadLen;
  info.simStep = u64(dv, at + 64);
  for (let i = 0; i < 3; i++) info.headPosition[i] = dv.getFloat32(at + 72 + 4 * i, true);
  for (let i = 0; i < 4; i++) info.headOrientation[i] = dv.getFloat32(at + 84 + 4 * i, true);
  return info;
}

// Throws the failure recorded at dv[at] (struct codec_core_error) of a frame of len bytes whose
// header record (as far as it was read) is at dv[hat].
function throwFailure(dv, at, hat, len) {
  const e = {
    code: dv.getInt32(at, true), byte: dv.getUint32(at + 4, true), index: dv.getUint32(at + 8, true),
    a: u64(dv, at + 16), b: u64(dv, at + 24), signedA: Number(dv.getBigInt64(at + 16, true)),
    norm2: dv.getFloat64(at + 16, true),
  };
  const h = readInfo(dv, hat, newFrameInfo());
  const text = MESSAGES.get(e.code) ?? (() => `decode core failure ${e.code}`);
  let where;
  if (e.code >= E.TABLE_SHORT && e.code <= E.TABLE_SUM) where = `table ${e.index}, byte ${e.byte}`;
  else if (e.code >= E.SYMBOL && e.code <= E.VALUE) {
    where = `strands ${e.index}-${Math.min(e.index + 7, h.nstrandsSent - 1)}, byte ${e.byte}`;
  } else where = `${FIELDS.get(e.code) ?? 'frame'}, byte ${e.byte}`;
  fail(`${text(h, e, len)} [${where}]`);
}

/**
 * A fresh header record (fields as in codec_frame_info; codec is the codec id, CODEC_ID_STRAND or
 * CODEC_ID_HAIRMESH, whose strands are the mesh's columns and nverts its layers): simStep is the simulation's step counter
 * (exact below 2^53), headPosition [x, y, z] (m) and headOrientation [x, y, z, w] (a unit
 * quaternion) the head transform that step used.
 */
export function newFrameInfo() {
  return {
    seq: 0, refSeq: 0, simTime: 0, simStep: 0, headPosition: new Float64Array(3),
    headOrientation: Float64Array.of(0, 0, 0, 1), step: 0, maxError: 0, keyframe: false, codec: 0,
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
  const c = scratchCore(INFO_SIZE + ERROR_SIZE + HEADER_SIZE);
  const hat = c.heap, eat = c.heap + INFO_SIZE, at = eat + ERROR_SIZE;
  c.u8.fill(0, hat, at);
  c.u8.set(bytes.subarray(0, HEADER_SIZE), at);
  if (c.x.codec_core_header(hat, eat, at, bytes.length) !== 0) throwFailure(c.dv, eat, hat, bytes.length);
  return readInfo(c.dv, hat, info);
}

/** zlib CRC-32 of bytes[from, to) (a Uint8Array), continuing from crc (0 to start): the core's. */
export function crc32(bytes, from, to, crc) {
  const c = scratchCore(to - from);
  c.u8.set(bytes.subarray(from, to), c.heap);
  return c.x.codec_core_crc32(crc | 0, c.heap, to - from) >>> 0;
}

/**
 * Byte offsets, past heap (where the core's state ends), of the regions of a decoder for frames of
 * nq lattice coordinates whose clamped segments take seg int16 and whose bytes take frameCap: two
 * lattice slots (Int32), two segment slots (Int16), two outputs (Float32), the frame's bytes
 * (READ_SLACK readable bytes after them), and the bytes in all.
 */
export function coreLayout(heap, nq, seg, frameCap) {
  const q0 = heap, q1 = q0 + 4 * nq, segBytes = (2 * seg + 15) & ~15;
  const d0 = (q1 + 4 * nq + 15) & ~15, d1 = d0 + segBytes, out0 = d1 + segBytes, out1 = out0 + 4 * nq;
  const bytes = out1 + 4 * nq;
  return { q: [q0, q1], d: [d0, d1], out: [out0, out1], bytes, end: bytes + frameCap + 16 + READ_SLACK };
}

/**
 * Decodes a stream of strand frames or of hair mesh frames (the same decoding; info.codec says
 * which, and a delta must be of its keyframe's codec). decode() returns a record (reused between calls) holding the
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
    this._hdr = newFrameInfo(); // the header of the frame being decoded
    this._core = null;     // a CoreMemory, replaced when the regions grow
    this._nqCap = 0;       // lattice coordinates its regions hold
    this._segCap = 0;      // clamped segments (int16) its segment slots hold
    this._bytesCap = 0;    // frame bytes it holds
    this._lay = null;      // coreLayout of its regions
    this._outViews = [null, null]; // the outputs' Float32Array views as returned
    this._next = 0;        // the output the next frame is decoded into
  }

  /** True when a keyframe is held (deltas against it can be decoded). */
  get hasKeyframe() { return this._core !== null && this._core.dv.getUint32(this._core.base + KEY_VALID, true) !== 0; }

  /** Sequence number of the held keyframe (-1 when none). */
  get keySeq() { return this.hasKeyframe ? u64(this._core.dv, this._core.base + KEY) : -1; }

  /** Forgets the held keyframe (e.g. after a reconnect). */
  reset() { if (this._core) this._core.x.codec_core_reset(this._core.base); }

  // Makes the regions hold nq coordinates, seg segments and a frame of frameLen bytes, keeping the
  // held keyframe (a new memory and instance when they grow: the state and the held slots move).
  _reserve(nq, seg, frameLen) {
    if (this._core && nq <= this._nqCap && seg <= this._segCap && frameLen <= this._bytesCap) return;
    const nqCap = Math.max(nq, this._nqCap), segCap = Math.max(seg, this._segCap);
    const bytesCap = Math.max(frameLen + (frameLen >> 2), this._bytesCap, PAGE);
    const probe = this._core ?? new CoreMemory(0);
    const lay = coreLayout(probe.heap, nqCap, segCap, bytesCap);
    const core = new CoreMemory(lay.end - probe.heap);
    const old = this._core;
    if (old) {
      core.u8.set(old.u8.subarray(old.base, old.heap), core.base);
      const s = old.dv.getUint32(old.base + KEY_SLOT, true), kq = this._nqCap, ks = this._segCap;
      core.u8.set(old.u8.subarray(this._lay.q[s], this._lay.q[s] + 4 * kq), lay.q[s]);
      core.u8.set(old.u8.subarray(this._lay.d[s], this._lay.d[s] + 2 * ks), lay.d[s]);
    }
    core.x.codec_core_regions(core.base, lay.q[0], lay.q[1], lay.d[0], lay.d[1]);
    this._core = core;
    this._lay = lay;
    this._nqCap = nqCap;
    this._segCap = segCap;
    this._bytesCap = bytesCap;
    this._outViews = [null, null];
  }

  // Copies the frame into the core's memory, zeros after it; returns its offset.
  _place(bytes) {
    const c = this._core, at = this._lay.bytes;
    c.u8.set(bytes, at);
    c.u8.fill(0, at + bytes.length, at + bytes.length + 16);
    return at;
  }

  /** Decodes one frame (a Uint8Array holding exactly the frame). */
  decode(bytes) {
    if (!(bytes instanceof Uint8Array)) fail('frame must be a Uint8Array');
    const len = bytes.length;
    // the header, the CRC and the reference are checked before the regions grow to the counts
    this._reserve(this._nqCap, this._segCap, len);
    let c = this._core, at = this._place(bytes);
    if (c.x.codec_core_check(c.base, at, len) !== 0) throwFailure(c.dv, c.base + ERROR, c.base + INFO, len);
    const h = readInfo(c.dv, c.base + INFO, this._hdr);
    const nq = h.nstrandsSent * h.nverts * 3, seg = c.x.codec_core_seg_len(h.nstrandsSent, h.nverts);
    if (nq > this._nqCap || seg > this._segCap) {
      this._reserve(nq, seg, len);
      c = this._core;
      at = this._place(bytes);
      if (c.x.codec_core_check(c.base, at, len) !== 0) throwFailure(c.dv, c.base + ERROR, c.base + INFO, len);
    }
    const k = this._next, out = this._lay.out[k];
    if (c.x.codec_core_decode(c.base, at, len, out) !== 0) throwFailure(c.dv, c.base + ERROR, c.base + INFO, len);
    const info = this.info, view = this._outViews[k];
    info.positions = view && view.length === nq ? view : (this._outViews[k] = new Float32Array(c.memory.buffer, out, nq));
    this._next = k ^ 1;
    readInfo(c.dv, c.base + INFO, info);
    return info;
  }
}
