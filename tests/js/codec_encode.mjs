// A small reference encoder of strand frames (proto/CODEC.md, version 3) for the tests of
// web/codec.js: it codes given lattice coordinates with given per-strand modes, written
// straight from the spec (and independent of the decoder), so that the tests can build frames
// the vectors do not have (escapes of every size, all modes, crafted corruptions).

export const VERSION = 3;
export const HEADER = 104;
const SCALE = 4096;
const LANES = 8;

function classOf(m) {
  if (m === 0) return 0;
  if (m >= 32) return 6;
  return 32 - Math.clz32(m);
}

const half = (d) => (d + ((d >> 1) & 1)) >> 1;
const clamp = (v, lim) => Math.max(-lim, Math.min(lim, v));

/** The moved root of k (an [x, y, z] lattice point) under motion { rho: 9 ints, t: 3 ints }. */
export function movedRoot(motion, k) {
  const out = [0, 0, 0];
  for (let a = 0; a < 3; a++) {
    const r = motion.rho.slice(3 * a, 3 * a + 3);
    const v = Math.floor((r[0] * k[0] + r[1] * k[1] + r[2] * k[2] + 8192) / 16384) + motion.t[a];
    out[a] = clamp(v, (1 << 26) - 1);
  }
  return out;
}

/** The moved segment S[v] of a held keyframe strand kv (lattice, 3 per vertex) at vertex v >= 1. */
export function movedSegment(motion, kv, v) {
  const d = [0, 1, 2].map((a) => clamp(kv[3 * v + a] - kv[3 * (v - 1) + a], 32767));
  return [0, 1, 2].map((a) => {
    const r = motion.rho;
    return (Math.imul(r[3 * a], d[0]) + Math.imul(r[3 * a + 1], d[1]) + Math.imul(r[3 * a + 2], d[2]) + 8192) >> 14;
  });
}

/**
 * The prediction of strand j's vertex v axis a (CODEC.md, Prediction). q: the frame's lattice
 * (strand-major, nverts per strand), key: the held keyframe's lattice (deltas), motion.
 */
export function predict(f, q, j, v, a) {
  const per = 3 * f.nverts, P = (w) => q[j * per + 3 * w + a], N = (w) => q[(j - 1) * per + 3 * w + a];
  const m = f.modes[j], hasN = j > 0;
  if (f.key) {
    if (v === 0) return hasN ? N(0) : 0;
    if (m === 1 && hasN) return P(v - 1) + N(v) - N(v - 1);
    if (v === 1) return hasN ? P(0) + N(1) - N(0) : P(0);
    if (m === 2 && v >= 3) return P(v - 1) + half(P(v - 1) - P(v - 3));
    return 2 * P(v - 1) - P(v - 2);
  }
  const kstrand = (s) => f.keyQ.subarray(s * per, (s + 1) * per);
  if (v === 0) {
    const K0 = movedRoot(f.motion, kstrand(j).subarray(0, 3))[a];
    return hasN ? K0 + N(0) - movedRoot(f.motion, kstrand(j - 1).subarray(0, 3))[a] : K0;
  }
  const S = (w) => movedSegment(f.motion, kstrand(j), w)[a];
  if (m === 1 && v >= 2) return P(v - 1) + S(v) + (P(v - 1) - P(v - 2)) - S(v - 1);
  if (m === 2 && v >= 2) return 2 * P(v - 1) - P(v - 2);
  if (m === 3 && v === 2) return 2 * P(v - 1) - P(v - 2);
  if (m === 3 && v >= 3) return P(v - 1) + half(P(v - 1) - P(v - 3));
  return P(v - 1) + S(v);
}

class BitWriter {
  constructor() { this.bytes = []; this.n = 0; }
  put(value, nbits) {
    for (let k = 0; k < nbits; k++) {
      if ((this.n & 7) === 0) this.bytes.push(0);
      if ((value / 2 ** k) & 1) this.bytes[this.bytes.length - 1] |= 1 << (this.n & 7);
      this.n++;
    }
  }
}

function varint(out, v) {
  if (v < 128) out.push(v);
  else out.push((v & 127) | 128, v >> 7);
}

// Frequencies summing to 4096 from counts (every counted symbol at least 1).
function normalize(counts) {
  const syms = [...counts.keys()].sort((a, b) => a - b);
  const total = syms.reduce((s, k) => s + counts.get(k), 0);
  const freq = new Map(syms.map((k) => [k, Math.max(1, Math.floor((counts.get(k) * SCALE) / total))]));
  let sum = syms.reduce((s, k) => s + freq.get(k), 0);
  while (sum !== SCALE) {
    const big = syms.reduce((b, k) => (freq.get(k) > freq.get(b) ? k : b), syms[0]);
    const d = sum > SCALE ? -Math.min(sum - SCALE, freq.get(big) - 1) : SCALE - sum;
    freq.set(big, freq.get(big) + d);
    sum += d;
  }
  return freq;
}

/**
 * Encodes a frame. f: { key, seq, refSeq, simTime, simStep, headPosition [x, y, z], headOrientation
 * [x, y, z, w] (0, identity by default), step, maxError, nstrandsTotal, stride, nverts,
 * q (Int32Array: the lattice of the strands sent), modes (one per strand sent), and for deltas
 * keyQ (the held keyframe's lattice) and motion { rho, t } }; optional escapeExp(e) to change the
 * exponent written in an escape's 5-bit field, states (8 initial encoder states, 2^16 by default)
 * and tableBytes (written instead of the tables the symbols were coded with). Returns
 * { bytes (Uint8Array), payload offsets: ransLenAt, ransAt, bitsAt, tablesAt }.
 */
export function encodeFrame(f) {
  const ns = f.q.length / (3 * f.nverts), nverts = f.nverts, per = 3 * nverts;
  const syms = []; // decode order: { lane, table, sym, raw: [[value, bits], ...] }
  for (let g = 0; g < ns; g += LANES) {
    const n = Math.min(LANES, ns - g);
    for (let l = 0; l < n; l++) syms.push({ lane: l, table: 0, sym: f.modes[g + l], raw: [] });
    const table = new Array(n).fill(1);
    for (let v = 0; v < nverts; v++) {
      for (let l = 0; l < n; l++) {
        const j = g + l, cls = [], raw = [];
        for (let a = 0; a < 3; a++) {
          const r = f.q[j * per + 3 * v + a] - predict(f, f.q, j, v, a);
          const m = Math.abs(r), c = classOf(m), sign = r < 0 ? 1 : 0;
          cls.push(c);
          if (c >= 1 && c <= 5) raw.push([sign | ((m - (1 << (c - 1))) << 1), c]);
          if (c === 6) {
            const e = 31 - Math.clz32(m);
            raw.push([f.escapeExp ? f.escapeExp(e) - 5 : e - 5, 5], [sign, 1], [m - 2 ** e, e]);
          }
        }
        syms.push({ lane: l, table: table[l], sym: cls[0] + 7 * cls[1] + 49 * cls[2], raw });
        table[l] = v === 0 ? 2 : 3 + Math.min(Math.max(...cls), 5);
      }
    }
  }
  const counts = Array.from({ length: 9 }, () => new Map());
  for (const s of syms) counts[s.table].set(s.sym, (counts[s.table].get(s.sym) || 0) + 1);
  const freqs = counts.map((c) => (c.size ? normalize(c) : new Map()));
  const starts = freqs.map((fr) => { let st = 0; const m = new Map(); for (const [k, v] of fr) { m.set(k, st); st += v; } return m; });

  const tables = [];
  for (const fr of freqs) {
    varint(tables, fr.size);
    let next = 0;
    for (const [k, v] of fr) { varint(tables, k - next); varint(tables, v); next = k + 1; }
  }
  // rANS, in reverse
  const x = (f.states || new Array(LANES).fill(1 << 16)).slice();
  const words = [];
  for (let i = syms.length - 1; i >= 0; i--) {
    const s = syms[i], fq = freqs[s.table].get(s.sym), st = starts[s.table].get(s.sym);
    let xs = x[s.lane];
    if (xs >= fq * 2 ** 20) { words.push(xs % 65536); xs = Math.floor(xs / 65536); }
    x[s.lane] = Math.floor(xs / fq) * SCALE + (xs % fq) + st;
  }
  words.reverse();
  const rans = [];
  for (const v of x) rans.push(v & 255, (v >>> 8) & 255, (v >>> 16) & 255, v >>> 24);
  for (const w of words) rans.push(w & 255, w >> 8);
  const bw = new BitWriter();
  for (const s of syms) for (const [v, nb] of s.raw) bw.put(v, nb);

  const payload = [];
  if (!f.key) {
    const mb = new DataView(new ArrayBuffer(48));
    f.motion.rho.forEach((r, k) => mb.setInt16(2 * k, r, true));
    f.motion.t.forEach((t, k) => mb.setInt32(20 + 4 * k, t, true));
    payload.push(...new Uint8Array(mb.buffer));
  }
  const tablesAt = HEADER + payload.length;
  for (const b of f.tableBytes || tables) payload.push(b);
  const ransLenAt = HEADER + payload.length;
  payload.push(rans.length & 255, (rans.length >> 8) & 255, (rans.length >> 16) & 255, rans.length >>> 24);
  const ransAt = HEADER + payload.length;
  for (const b of rans) payload.push(b);
  const bitsAt = HEADER + payload.length;
  for (const b of bw.bytes) payload.push(b);

  const bytes = new Uint8Array(HEADER + payload.length);
  const dv = new DataView(bytes.buffer);
  bytes.set([0x53, 0x43, 0x46, 0x31]);
  dv.setUint16(4, VERSION, true);
  bytes[6] = 1;
  bytes[7] = f.key ? 1 : 0;
  dv.setBigUint64(8, BigInt(f.seq), true);
  dv.setBigUint64(16, BigInt(f.key ? f.seq : f.refSeq), true);
  dv.setFloat64(24, f.simTime ?? 0, true);
  dv.setFloat64(32, f.step, true);
  dv.setFloat32(40, f.maxError, true);
  dv.setUint32(44, f.nstrandsTotal ?? ns, true);
  dv.setUint32(48, ns, true);
  dv.setUint32(52, nverts, true);
  dv.setUint32(56, f.stride ?? 1, true);
  dv.setUint32(60, payload.length, true);
  dv.setBigUint64(64, BigInt(f.simStep ?? 0), true);
  (f.headPosition ?? [0, 0, 0]).forEach((v, k) => dv.setFloat32(72 + 4 * k, v, true));
  (f.headOrientation ?? [0, 0, 0, 1]).forEach((v, k) => dv.setFloat32(84 + 4 * k, v, true));
  bytes.set(payload, HEADER);
  stampCrc(bytes);
  return { bytes, tablesAt, ransLenAt, ransAt, bitsAt };
}

/** zlib CRC-32 of bytes, bit by bit. */
export function crc32(bytes) {
  let c = -1;
  for (const b of bytes) {
    c ^= b;
    for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
  }
  return ~c >>> 0;
}

/** Rewrites the CRC field of a frame after an edit. */
export function stampCrc(frame) {
  const body = new Uint8Array(frame.length - 4);
  body.set(frame.subarray(0, HEADER - 4));
  body.set(frame.subarray(HEADER), HEADER - 4);
  new DataView(frame.buffer, frame.byteOffset).setUint32(HEADER - 4, crc32(body), true);
}
