// Node half of `strandbench codec`: meshoptimizer's vertex codec + deflate on the quantized
// frames dumped by the C bench, and the JavaScript strand decoder's speed and bit-exactness.
// Usage: node codec_js_bench.mjs --quant FILE --strand FILE [--cpu-time]   (prints one JSON line each)
import { readFileSync } from 'node:fs';
import { deflateSync, inflateSync, crc32 as zcrc32 } from 'node:zlib';
import { MeshoptEncoder, MeshoptDecoder } from 'meshoptimizer';

import { StrandDecoder } from '../../web/codec.js';

const args = process.argv.slice(2);
const opt = (name) => { const i = args.indexOf(name); return i >= 0 ? args[i + 1] : undefined; };
// nanoseconds: wall clock, or with --cpu-time this process's CPU time (a loaded host does not inflate it)
const now = args.includes('--cpu-time')
  ? () => { const u = process.cpuUsage(); return (u.user + u.system) * 1000; }
  : () => Number(process.hrtime.bigint());
const median = (v) => { const s = Float64Array.from(v).sort(); return s.length ? s[s.length >> 1] : 0; };

function crc32(bytes) {
  if (zcrc32) return zcrc32(bytes) >>> 0;
  let c = -1;
  for (const b of bytes) { c ^= b; for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1; }
  return ~c >>> 0;
}

// SCQ1, u32 vertices, u32 frames; per frame: f32 lo[3], f64 step, u32 width, vertices x 3 ints.
async function meshopt(path) {
  await MeshoptEncoder.ready;
  await MeshoptDecoder.ready;
  const buf = readFileSync(path);
  const dv = new DataView(buf.buffer, buf.byteOffset, buf.byteLength);
  if (buf.toString('latin1', 0, 4) !== 'SCQ1') throw new Error('bad quant dump');
  const nv = dv.getUint32(4, true), nf = dv.getUint32(8, true);
  let off = 12, bytes = 0;
  const enc = [], dec = [];
  for (let f = 0; f < nf; f++) {
    const lo = [dv.getFloat32(off, true), dv.getFloat32(off + 4, true), dv.getFloat32(off + 8, true)];
    const step = dv.getFloat64(off + 12, true), width = dv.getUint32(off + 20, true);
    off += 24;
    const ints = width === 2 ? new Uint16Array(buf.buffer.slice(buf.byteOffset + off, buf.byteOffset + off + nv * 6))
      : new Uint32Array(buf.buffer.slice(buf.byteOffset + off, buf.byteOffset + off + nv * 12));
    off += nv * 3 * width;
    // meshopt vertex: 16-bit xyz padded to 8 bytes, or 32-bit xyz (12 bytes)
    const size = width === 2 ? 8 : 12;
    const out = new Float32Array(nv * 3);
    const t0 = now();
    let vb;
    if (width === 2) {
      const v = new Uint16Array(nv * 4);
      for (let i = 0; i < nv; i++) { v[4 * i] = ints[3 * i]; v[4 * i + 1] = ints[3 * i + 1]; v[4 * i + 2] = ints[3 * i + 2]; }
      vb = new Uint8Array(v.buffer);
    } else {
      vb = new Uint8Array(ints.buffer);
    }
    const coded = MeshoptEncoder.encodeVertexBufferLevel(vb, nv, size, 3, 1);
    const z = deflateSync(coded, { level: 6 });
    const t1 = now();
    const unz = inflateSync(z);
    const back = new Uint8Array(nv * size);
    MeshoptDecoder.decodeVertexBuffer(back, nv, size, new Uint8Array(unz.buffer, unz.byteOffset, unz.byteLength));
    if (width === 2) {
      const v = new Uint16Array(back.buffer);
      for (let i = 0; i < nv; i++) for (let a = 0; a < 3; a++) out[3 * i + a] = lo[a] + v[4 * i + a] * step;
    } else {
      const v = new Uint32Array(back.buffer);
      for (let i = 0; i < nv * 3; i++) out[i] = lo[i % 3] + v[i] * step;
    }
    const t2 = now();
    const src = new Uint8Array(vb.buffer, vb.byteOffset, vb.byteLength);
    for (let i = 0; i < src.length; i++) if (src[i] !== back[i]) throw new Error(`meshopt round trip differs in frame ${f}`);
    bytes += z.length + 32;
    enc.push(t1 - t0);
    dec.push(t2 - t1);
  }
  console.log(JSON.stringify({
    codec: 'quant+meshopt+deflate', bytes_per_vertex: +(bytes / (nv * nf)).toFixed(4),
    encode_ns_per_vertex: +(median(enc) / nv).toFixed(2), decode_ns_per_vertex: +(median(dec) / nv).toFixed(2), frames: nf,
  }));
}

// SCS1, u32 frames; per frame: u32 length, u32 CRC-32 of the C decoder's float32 output, bytes.
function strand(path) {
  const buf = readFileSync(path);
  const dv = new DataView(buf.buffer, buf.byteOffset, buf.byteLength);
  if (buf.toString('latin1', 0, 4) !== 'SCS1') throw new Error('bad strand dump');
  const nf = dv.getUint32(4, true);
  const frames = [], crcs = [];
  let off = 8;
  for (let f = 0; f < nf; f++) {
    const len = dv.getUint32(off, true);
    crcs.push(dv.getUint32(off + 4, true));
    frames.push(new Uint8Array(buf.buffer, buf.byteOffset + off + 8, len));
    off += 8 + len;
  }
  const dec = new StrandDecoder();
  let exact = 1, nv = 0;
  for (let f = 0; f < nf; f++) { // first pass: correctness against the C decoder
    const info = dec.decode(frames[f]);
    const p = info.positions;
    nv = p.length / 3;
    if (crc32(new Uint8Array(p.buffer, p.byteOffset, p.byteLength)) !== crcs[f]) exact = 0;
  }
  const times = [], keyTimes = [];
  for (let rep = 0; rep < 5; rep++) {
    dec.reset();
    for (let f = 0; f < nf; f++) {
      const t0 = now();
      const key = dec.decode(frames[f]).keyframe;
      const t = now() - t0;
      times.push(t);
      if (key) keyTimes.push(t);
    }
  }
  console.log(`{"codec":"strand","js_decode_ns_per_vertex":${(median(times) / nv).toFixed(2)},"bit_exact":${exact},` +
    `"js_key_decode_ns_per_vertex":${(median(keyTimes) / nv).toFixed(2)}}`);
}

const q = opt('--quant'), s = opt('--strand');
if (!q && !s) {
  console.error('usage: node codec_js_bench.mjs --quant FILE --strand FILE');
  process.exit(2);
}
if (q) await meshopt(q);
if (s) strand(s);
