// Tests for web/codec.js, the loader of the decode core (server/codec/codec_core.c as WebAssembly;
// frame format version 2): bit-exact decoding of proto/vectors, frame skipping, frames of every
// mode, escape and group shape built by the reference encoder written from CODEC.md
// (codec_encode.mjs; the modes vectors are its frames, stored for the C build too), every
// rejection of CODEC.md (truncated, bit-flipped, version 1, bad states, stream lengths, motion,
// tables, escapes, coordinates), each leaving the decoder unchanged, a worst-case overrun refused
// inside the core's memory; the CRC, the decoder's memory layout (run with `node --test`).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync, writeFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

import {
  StrandDecoder, peekHeader, crc32 as codecCrc32, HEADER_SIZE, coreLayout, READ_SLACK, CODEC_ID_STRAND, CODEC_ID_HAIRMESH,
} from '../../web/codec.js';
import { KERNEL_WASM } from '../../web/codec_kernel_wasm.js';
import { encodeFrame, stampCrc } from './codec_encode.mjs';
import { MODE_SHAPES, MODE_STEP, modeStream } from './mode_vectors.mjs';

const here = dirname(fileURLToPath(import.meta.url));
const vdir = join(here, '..', '..', 'proto', 'vectors');
const manifest = JSON.parse(readFileSync(join(vdir, 'manifest.json'), 'utf8'));
const load = (name) => new Uint8Array(readFileSync(join(vdir, name)));

function crc32(bytes) {
  let c = -1;
  for (const b of bytes) {
    c ^= b;
    for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
  }
  return ~c >>> 0;
}

function restampCrc(frame) {
  const body = new Uint8Array(frame.length - 4);
  body.set(frame.subarray(0, HEADER_SIZE - 4));
  body.set(frame.subarray(HEADER_SIZE), HEADER_SIZE - 4);
  const c = crc32(body);
  for (let k = 0; k < 4; k++) frame[HEADER_SIZE - 4 + k] = (c >>> (8 * k)) & 0xff;
}

function put32(b, o, v) { for (let k = 0; k < 4; k++) b[o + k] = (v >>> (8 * k)) & 0xff; }

function rng(seed) {
  let s = seed >>> 0;
  return () => { s = (Math.imul(s, 1664525) + 1013904223) >>> 0; return s; };
}

function sameBits(positions, file) {
  const got = new Uint8Array(positions.buffer, positions.byteOffset, positions.byteLength);
  const want = load(file);
  assert.equal(got.length, want.length, `${file}: length`);
  for (let i = 0; i < want.length; i++) {
    if (got[i] !== want[i]) assert.fail(`${file}: byte ${i} differs (${got[i]} vs ${want[i]})`);
  }
}

test('manifest describes the format this decoder reads', () => {
  assert.equal(manifest.format_version, 3);
  assert.ok(manifest.streams.length >= 4);
  assert.ok(manifest.streams.some((s) => s.stride > 1));
  assert.ok(manifest.streams.some((s) => s.nstrands_sent % 8 !== 0), 'a stream with a partial group of 8');
  assert.ok(manifest.streams.some((s) => s.nstrands_sent > 8), 'a stream with more than one group');
  assert.ok(manifest.streams.some((s) => s.codec === CODEC_ID_HAIRMESH), 'a hair mesh stream');
  assert.ok(manifest.streams.every((s) => s.codec === CODEC_ID_STRAND || s.codec === CODEC_ID_HAIRMESH));
});

test('every vector decodes bit for bit, in order and with frames skipped', () => {
  for (const s of manifest.streams) {
    for (const pass of [0, 1]) {
      const dec = new StrandDecoder();
      let last = [], n = 0;
      s.frames.forEach((f, idx) => {
        if (pass === 1 && !f.keyframe && idx !== s.frames.length - 1) return;
        const bytes = load(f.file + '.bin');
        assert.equal(bytes.length, f.bytes);
        const info = dec.decode(bytes);
        assert.equal(info.seq, f.seq);
        assert.equal(info.refSeq, f.ref_seq);
        assert.equal(info.keyframe, f.keyframe);
        assert.equal(info.simTime, f.sim_time);
        assert.equal(info.simStep, f.sim_step);
        assert.deepEqual([...info.headPosition], f.head_position.map(Math.fround));
        assert.deepEqual([...info.headOrientation], f.head_orientation.map(Math.fround));
        assert.equal(info.nstrandsSent, s.nstrands_sent);
        assert.equal(info.nstrandsTotal, s.nstrands);
        assert.equal(info.nverts, s.nverts);
        assert.equal(info.stride, s.stride);
        assert.equal(info.codec, s.codec);
        assert.equal(info.maxError, Math.fround(s.max_error_m));
        assert.equal(info.positions.length, s.nstrands_sent * s.nverts * 3);
        sameBits(info.positions, f.file + '.out.f32');
        if (last.length === 2) assert.equal(info.positions, last[0], 'two positions arrays in turn');
        if (last.length) assert.notEqual(info.positions, last[last.length - 1]);
        last = [...last, info.positions].slice(-2);
        n++;
      });
      assert.ok(n >= 2);
    }
  }
});

test('decoded positions are within the stated bound of the encoder input', () => {
  for (const s of manifest.streams) {
    const dec = new StrandDecoder();
    for (const f of s.frames) {
      const { positions } = dec.decode(load(f.file + '.bin'));
      const inp = new Float32Array(load(f.file + '.in.f32').buffer.slice(0));
      const per = s.nverts * 3;
      for (let j = 0; j < s.nstrands_sent; j++) {
        for (let i = 0; i < per; i++) {
          const e = Math.abs(positions[j * per + i] - inp[j * s.stride * per + i]);
          assert.ok(e <= Math.fround(s.max_error_m), `${f.file}: error ${e}`);
        }
      }
    }
  }
});

const basic = manifest.streams[0];
const keyBytes = () => load(basic.frames[0].file + '.bin');
const deltaBytes = () => load(basic.frames[1].file + '.bin');

test('a delta needs its keyframe', () => {
  const dec = new StrandDecoder();
  assert.throws(() => dec.decode(deltaBytes()), /needs keyframe 1000, which is not held/);
  assert.equal(dec.hasKeyframe, false);
  dec.decode(keyBytes());
  assert.equal(dec.keySeq, 1000);
  dec.decode(deltaBytes());
  const later = basic.frames.find((f, i) => i > 0 && f.keyframe);
  dec.decode(load(later.file + '.bin'));
  assert.throws(() => dec.decode(deltaBytes()), /not held/);
  dec.reset();
  assert.equal(dec.hasKeyframe, false);
});

test('every truncated prefix is rejected and the held keyframe survives', () => {
  for (const full of [keyBytes(), deltaBytes()]) {
    const dec = new StrandDecoder();
    dec.decode(keyBytes());
    const before = Float32Array.from(dec.info.positions);
    for (let len = 0; len < full.length; len++) {
      const cut = full.slice(0, len);
      assert.throws(() => dec.decode(cut), /^Error: codec: /);
      if (len > HEADER_SIZE) { // claims to be complete: length and CRC fixed up
        put32(cut, 60, len - HEADER_SIZE);
        restampCrc(cut);
        assert.throws(() => dec.decode(cut), /^Error: codec: /);
      }
    }
    assert.deepEqual(dec.info.positions, before);
    dec.decode(deltaBytes());
    sameBits(dec.info.positions, basic.frames[1].file + '.out.f32');
  }
});

test('random bit flips are rejected (seeded)', () => {
  const next = rng(12345);
  let deepRejected = 0, deepDecoded = 0;
  for (const full of [keyBytes(), deltaBytes()]) {
    const dec = new StrandDecoder();
    dec.decode(keyBytes());
    for (let trial = 0; trial < 400; trial++) {
      const c = full.slice();
      const flips = 1 + (next() % 3);
      for (let k = 0; k < flips; k++) { const bit = next() % (c.length * 8); c[bit >> 3] ^= 1 << (bit & 7); }
      if (c.every((b, i) => b === full[i])) continue;
      assert.throws(() => dec.decode(c), /^Error: codec: /);
      // past the CRC: must throw cleanly or give finite, in-range positions
      const d = full.slice();
      const bit = HEADER_SIZE * 8 + (next() % ((d.length - HEADER_SIZE) * 8));
      d[bit >> 3] ^= 1 << (bit & 7);
      restampCrc(d);
      try {
        const { positions } = dec.decode(d);
        for (const v of positions) assert.ok(Number.isFinite(v) && Math.abs(v) < 1e4);
        deepDecoded++;
        dec.decode(keyBytes());
      } catch (e) {
        assert.match(String(e), /^Error: codec: /);
        deepRejected++;
      }
    }
  }
  assert.ok(deepRejected > deepDecoded / 4, `${deepRejected} rejected, ${deepDecoded} decoded`);
});

test('absurd header fields are rejected', () => {
  const f64 = (b, o, v) => new DataView(b.buffer).setFloat64(o, v, true);
  const f32 = (b, o, v) => new DataView(b.buffer).setFloat32(o, v, true);
  const edits = [
    (c) => { c[0] = 0x58; }, (c) => { c[4] = 2; }, (c) => { c[6] = 9; }, (c) => { c[7] = 0x81; },
    (c) => { put32(c, 16, 0); put32(c, 20, 0); }, (c) => { c[7] = 0; },
    (c) => f64(c, 24, NaN), (c) => f64(c, 32, NaN), (c) => f64(c, 32, 0), (c) => f64(c, 32, 1e300),
    (c) => f32(c, 40, NaN), (c) => f32(c, 40, Infinity), (c) => f32(c, 40, 1e-7),
    (c) => put32(c, 44, 0), (c) => put32(c, 44, 0xffffffff), (c) => put32(c, 48, 0), (c) => put32(c, 48, 25),
    (c) => put32(c, 52, 0), (c) => put32(c, 52, 1), (c) => put32(c, 52, 0xffffffff),
    (c) => put32(c, 56, 0), (c) => put32(c, 56, 0xffffffff), (c) => put32(c, 60, 0xffffffff), (c) => put32(c, 60, 0),
    (c) => { put32(c, 44, 1 << 24); put32(c, 48, 1 << 24); },
    (c) => put32(c, 52, 11), (c) => { put32(c, 44, 23); put32(c, 48, 23); }, (c) => { c[HEADER_SIZE + 4] ^= 0xff; },
  ];
  edits.forEach((edit, i) => {
    const c = keyBytes();
    edit(c);
    restampCrc(c);
    const dec = new StrandDecoder();
    assert.throws(() => dec.decode(c), /^Error: codec: /, `edit ${i}`);
    if (i < 25) assert.throws(() => peekHeader(c), /^Error: codec: /, `peek ${i}`);
  });
  assert.throws(() => peekHeader(new ArrayBuffer(100)), /Uint8Array/);
});

// Every rejection below: a clear message, and the decoder unchanged (held keyframe, output).
function rejects(dec, frame, pattern) {
  const seq = dec.keySeq, before = Float32Array.from(dec.info.positions);
  assert.throws(() => dec.decode(frame), pattern);
  assert.equal(dec.keySeq, seq, 'held keyframe unchanged');
  assert.deepEqual(dec.info.positions, before, 'output unchanged');
}

test('version 2 frames are refused', () => {
  const c = keyBytes();
  c[4] = 2;
  stampCrc(c);
  assert.throws(() => peekHeader(c), /unsupported format version 2/);
  const dec = new StrandDecoder();
  dec.decode(keyBytes());
  rejects(dec, c, /^Error: codec: unsupported format version 2 \(this decoder reads 3\) \[version, byte 4\]$/);
});

test('a header whose head transform is not finite or not a unit rotation is refused', () => {
  const f32 = (b, o, v) => new DataView(b.buffer, b.byteOffset).setFloat32(o, v, true);
  const cases = [
    [(c) => f32(c, 72, NaN), /^Error: codec: head position is not finite \[head, byte 72\]$/],
    [(c) => f32(c, 80, -Infinity), /^Error: codec: head position is not finite \[head, byte 80\]$/],
    [(c) => f32(c, 88, NaN), /^Error: codec: head rotation is not finite \[head, byte 88\]$/],
    [(c) => { [0, 0, 0, 0.5].forEach((v, k) => f32(c, 84 + 4 * k, v)); },
      /^Error: codec: head rotation is not a unit quaternion \(squared norm 0\.25, not within 0\.0001 of 1\) \[head, byte 84\]$/],
    [(c) => { [0, 0, 0, 0].forEach((v, k) => f32(c, 84 + 4 * k, v)); }, /squared norm 0, not within/],
    [(c) => { [0.6, 0.8, 0, 0.02].forEach((v, k) => f32(c, 84 + 4 * k, v)); }, /squared norm 1\.0004/],
  ];
  const dec = new StrandDecoder();
  dec.decode(keyBytes());
  for (const [edit, pattern] of cases) {
    const c = keyBytes();
    edit(c);
    stampCrc(c);
    assert.throws(() => peekHeader(c), pattern);
    rejects(dec, c, pattern);
  }
  // within the tolerance: accepted, and read as written
  const c = keyBytes();
  [0, 0, 0, 1.00004].forEach((v, k) => f32(c, 84 + 4 * k, v));
  [1, -2, 3].forEach((v, k) => f32(c, 72 + 4 * k, v));
  new DataView(c.buffer).setBigUint64(64, 123456789n, true);
  stampCrc(c);
  const info = dec.decode(c);
  assert.deepEqual([...info.headOrientation], [0, 0, 0, Math.fround(1.00004)]);
  assert.deepEqual([...info.headPosition], [1, -2, 3]);
  assert.equal(info.simStep, 123456789);
});

test('a delta whose rigid motion is out of range or badly padded is refused', () => {
  const dec = new StrandDecoder();
  dec.decode(keyBytes());
  const dv = (b) => new DataView(b.buffer, b.byteOffset);
  const edits = [
    (d) => dv(d).setInt16(HEADER_SIZE, 16385, true), (d) => dv(d).setInt16(HEADER_SIZE + 16, -16385, true),
    (d) => dv(d).setInt16(HEADER_SIZE + 8, -32768, true),
    (d) => { d[HEADER_SIZE + 18] = 1; }, (d) => { d[HEADER_SIZE + 19] = 0x80; },
    (d) => dv(d).setInt32(HEADER_SIZE + 20, 2 ** 28 + 1, true), (d) => dv(d).setInt32(HEADER_SIZE + 28, -(2 ** 28) - 1, true),
    (d) => dv(d).setInt32(HEADER_SIZE + 24, -(2 ** 31), true),
    ...Array.from({ length: 16 }, (_, k) => (d) => { d[HEADER_SIZE + 32 + k] = 1 << (k & 7); }),
  ];
  edits.forEach((edit, i) => {
    const d = deltaBytes();
    edit(d);
    stampCrc(d);
    rejects(dec, d, /^Error: codec: invalid rigid motion/, `edit ${i}`);
  });
  sameBits(dec.decode(deltaBytes()).positions, basic.frames[1].file + '.out.f32');
});

test('the rotation and translation limits themselves are accepted', () => {
  const nverts = 4, ns = 3, step = 1.9375e-4;
  const kq = Int32Array.from({ length: ns * nverts * 3 }, (_, i) => ((i * 7919) % 4001) - 2000);
  const key = encodeFrame({ key: true, seq: 1, step, maxError: 1e-4, nverts, q: kq, modes: [0, 1, 2] });
  for (const motion of [{ rho: [16384, 0, 0, 0, -16384, 0, 0, 0, 16384], t: [2 ** 28, -(2 ** 28), 0] },
    { rho: [-16384, 16384, -16384, 16384, -16384, 16384, -16384, 16384, -16384], t: [-5, 0, 5] }]) {
    const q = kq.map((v, i) => v + (i % 5) - 2);
    const d = encodeFrame({ key: false, seq: 2, refSeq: 1, step, maxError: 1e-4, nverts, q, keyQ: kq, motion, modes: [0, 1, 3] });
    const dec = new StrandDecoder();
    dec.decode(key.bytes);
    const out = dec.decode(d.bytes).positions;
    q.forEach((v, i) => assert.equal(out[i], Math.fround(v * step)));
  }
});

// A seeded lattice of ns strands of nverts vertices: smooth strands, and with big jumps when
// `wild` (escapes of every size).
function lattice(ns, nverts, seed, wild) {
  const next = rng(seed);
  const q = new Int32Array(ns * nverts * 3);
  for (let j = 0; j < ns; j++) {
    for (let v = 0; v < nverts; v++) {
      for (let a = 0; a < 3; a++) {
        const jitter = wild && next() % 7 === 0 ? (next() % (1 << 25)) - (1 << 24) : (next() % 41) - 20;
        q[(j * nverts + v) * 3 + a] = 3000 * j + 700 * v * (a + 1) - 40000 + jitter;
      }
    }
  }
  return q;
}

test('frames of every mode, group shape and escape size decode exactly (reference encoder)', () => {
  const motion = { rho: [16380, 300, -200, -300, 16379, 150, 200, -150, 16381], t: [12345, -6789, 1011] };
  for (const [ns, nverts] of [[1, 2], [3, 3], [8, 4], [9, 2], [13, 9], [24, 12], [17, 33]]) {
    for (const wild of [false, true]) {
      const step = 1.9375e-4, maxError = 1e-4;
      const kq = lattice(ns, nverts, ns * 100 + nverts, wild);
      const dec = new StrandDecoder();
      const key = encodeFrame({ key: true, seq: 10, step, maxError, nverts, q: kq, modes: Array.from({ length: ns }, (_, j) => j % 3) });
      const ko = dec.decode(key.bytes).positions;
      kq.forEach((v, i) => { if (ko[i] !== Math.fround(v * step)) assert.fail(`key ${ns}x${nverts} wild ${wild}: coordinate ${i}`); });
      for (let m = 0; m < 4; m++) {
        const q = lattice(ns, nverts, 7 * m + ns, wild).map((v, i) => kq[i] + ((v % 61) - 30));
        const modes = Array.from({ length: ns }, (_, j) => (j + m) % 4);
        const d = encodeFrame({ key: false, seq: 11 + m, refSeq: 10, step, maxError, nverts, q, keyQ: kq, motion, modes });
        const o = dec.decode(d.bytes).positions;
        q.forEach((v, i) => { if (o[i] !== Math.fround(v * step)) assert.fail(`delta ${ns}x${nverts} wild ${wild} m ${m}: coordinate ${i}`); });
      }
    }
  }
});

test('moved segments clamp long keyframe segments to 15 bits', () => {
  const nverts = 3, step = 1e-5;
  const kq = Int32Array.from([0, 0, 0, 40000, -50000, 10, 40001, 60000, -32768]);
  const dec = new StrandDecoder();
  dec.decode(encodeFrame({ key: true, seq: 1, step, maxError: 1e-5, nverts, q: kq, modes: [0] }).bytes);
  const motion = { rho: [16000, 2000, -1000, -2000, 16000, 500, 1000, -500, 16300], t: [7, 8, 9] };
  for (const mode of [0, 1]) {
    const q = Int32Array.from(kq, (v, i) => v + 3 * i);
    const d = encodeFrame({ key: false, seq: 2 + mode, refSeq: 1, step, maxError: 1e-5, nverts, q, keyQ: kq, motion, modes: [mode] });
    const o = dec.decode(d.bytes).positions;
    q.forEach((v, i) => assert.equal(o[i], Math.fround(v * step)));
  }
});

test('the lanes past a keyframe\'s last strand hold no segments of an earlier keyframe', () => {
  // The decoder keeps two segment regions and writes each keyframe into the one not held. K1's
  // strands 13-15 (lanes 5-7 of group 1) rise by 32767 per segment; K3, two keyframes later in
  // the same region, has 13 strands. The delta's lanes past strand 12 move along those segments
  // unless K3 cleared them: 2199 x 32767 lies beyond 2^26 - 1, which the delta would refuse.
  const nverts = 2200, step = 1.9375e-4, maxError = 1e-4;
  const ramp = new Int32Array(16 * nverts * 3);
  for (let j = 0; j < 16; j++) for (let v = 0; v < nverts; v++) ramp[3 * (j * nverts + v)] = -36000000 + 32767 * v;
  const small = (ns, seed) => lattice(ns, nverts, seed, false);
  const k3 = small(13, 3);
  const dec = new StrandDecoder();
  dec.decode(encodeFrame({ key: true, seq: 1, step, maxError, nverts, q: ramp, modes: new Array(16).fill(0) }).bytes);
  dec.decode(encodeFrame({ key: true, seq: 2, step, maxError, nverts, q: small(16, 2), modes: new Array(16).fill(0) }).bytes);
  dec.decode(encodeFrame({ key: true, seq: 3, step, maxError, nverts, q: k3, modes: new Array(13).fill(0) }).bytes);
  const motion = { rho: [16384, 0, 0, 0, 16384, 0, 0, 0, 16384], t: [0, 0, 0] };
  const d = encodeFrame({ key: false, seq: 4, refSeq: 3, step, maxError, nverts, q: k3, keyQ: k3, motion,
    modes: new Array(13).fill(0) });
  const o = dec.decode(d.bytes).positions;
  k3.forEach((v, i) => { if (o[i] !== Math.fround(v * step)) assert.fail(`coordinate ${i}`); });
});

// A small keyframe (two groups, the second partial) and its encoder record, for the rejections.
const smallKey = (extra = {}) => encodeFrame({ key: true, seq: 1, step: 1.9375e-4, maxError: 1e-4, nverts: 5,
  q: lattice(11, 5, 4242, true), modes: Array.from({ length: 11 }, (_, j) => j % 3), ...extra });

function withHeldKey() {
  const dec = new StrandDecoder();
  dec.decode(keyBytes());
  return dec;
}

test('entropy stream lengths and states are checked', () => {
  const dec = withHeldKey();
  const base = smallKey();
  const dv = (b) => new DataView(b.buffer, b.byteOffset);
  const len = dv(base.bytes).getUint32(base.ransLenAt, true);
  for (const bad of [len + 1, len - 1, 30, 0, base.bytes.length]) {
    const c = base.bytes.slice();
    dv(c).setUint32(base.ransLenAt, bad, true);
    stampCrc(c);
    rejects(dec, c, /entropy stream length \d+ invalid/);
  }
  for (const [lane, state] of [[0, 0xffff], [7, 0], [3, 1]]) {
    const c = base.bytes.slice();
    dv(c).setUint32(base.ransAt + 4 * lane, state, true);
    stampCrc(c);
    rejects(dec, c, new RegExp(`invalid entropy coder state ${state} in lane ${lane}`));
  }
  // an encoder that starts a lane from another state: the stream does not end in 2^16
  rejects(dec, smallKey({ states: [65536, 65536, 65536, 65536, 65536, 65537, 65536, 65536] }).bytes,
    /entropy stream does not end in the initial states/);
  // a lane that codes nothing (5 strands: lanes 5..7) must still be 2^16; a 5-strand frame
  // decodes whatever the idle lanes' tables would give
  const five = encodeFrame({ key: true, seq: 1, step: 1.9375e-4, maxError: 1e-4, nverts: 3, q: lattice(5, 3, 99, true),
    modes: [0, 1, 2, 0, 1] });
  assert.equal(new StrandDecoder().decode(five.bytes).positions.length, 45);
  for (const lane of [5, 7]) {
    const idle = five.bytes.slice();
    dv(idle).setUint32(five.ransAt + 4 * lane, 65537, true);
    stampCrc(idle);
    rejects(dec, idle, /entropy stream does not end in the initial states/);
  }
  // a word too many, a word too few
  const grow = (b, at, n) => {
    const c = new Uint8Array(b.length + n);
    c.set(b.subarray(0, at));
    c.set(b.subarray(at - (n < 0 ? n : 0)), at + (n > 0 ? n : 0));
    dv(c).setUint32(60, c.length - HEADER_SIZE, true);
    dv(c).setUint32(base.ransLenAt, len + n, true);
    stampCrc(c);
    return c;
  };
  rejects(dec, grow(base.bytes, base.bitsAt, 2), /entropy stream does not end in the initial states with every word read/);
  rejects(dec, grow(base.bytes, base.bitsAt - 2, -2), /^Error: codec: (corrupt|entropy|raw bit)/);
  sameBits(dec.decode(deltaBytes()).positions, basic.frames[1].file + '.out.f32');
  const ok = new StrandDecoder();
  assert.equal(ok.decode(base.bytes).positions.length, 11 * 5 * 3);
});

test('the raw bit stream must be used up to its padding', () => {
  const dec = withHeldKey();
  const base = smallKey();
  const dv = (b) => new DataView(b.buffer, b.byteOffset);
  const longer = new Uint8Array(base.bytes.length + 1);
  longer.set(base.bytes);
  dv(longer).setUint32(60, longer.length - HEADER_SIZE, true);
  stampCrc(longer);
  const avail = (base.bytes.length - base.bitsAt) * 8;
  rejects(dec, longer, /raw bit stream is \d+ bits, frame used \d+/);
  const [, said, used] = /is (\d+) bits, frame used (\d+)/.exec((() => { try { dec.decode(longer); } catch (e) { return e.message; } })());
  assert.equal(+said, avail + 8);
  assert.ok(+used <= avail && +used > avail - 8, `used ${used} of ${avail}`);
  const shorter = base.bytes.slice(0, base.bytes.length - 1);
  dv(shorter).setUint32(60, shorter.length - HEADER_SIZE, true);
  stampCrc(shorter);
  rejects(dec, shorter, /raw bit stream is \d+ bits, frame used \d+/);
});

test('escape exponents above 24 are refused, 24 is accepted', () => {
  const dec = withHeldKey();
  const q = new Int32Array(2 * 3 * 3);
  q[4] = (1 << 29) + 12345; // vertex 1 y of strand 0: a residual of exponent 29
  q[5] = -(1 << 29);
  for (let i = 6; i < 9; i++) q[i] = q[i - 3];
  q.copyWithin(9, 0, 9);
  const f = { key: true, seq: 1, step: 1e-5, maxError: 1e-5, nverts: 3, q, modes: [0, 0] };
  // exponent 29 is field 24: decodes, then fails only on its coordinate range
  rejects(dec, encodeFrame(f).bytes, /decoded coordinate out of range/);
  rejects(dec, encodeFrame({ ...f, escapeExp: (e) => (e === 29 ? 30 : e) }).bytes, /escape exponent above 24/);
  const ok = Int32Array.from(q, (v) => v >> 4); // exponent 25: in range
  const out = new StrandDecoder().decode(encodeFrame({ ...f, q: ok }).bytes).positions;
  ok.forEach((v, i) => assert.equal(out[i], Math.fround(v * 1e-5)));
});

test('coordinates must stay below 2^26 in magnitude', () => {
  const lim = (1 << 26) - 1;
  for (const [v, good] of [[lim, true], [-lim, true], [lim + 1, false], [-lim - 1, false]]) {
    for (const at of [0, 4, 8]) { // a root, vertex 1, vertex 2 (linear)
      const q = new Int32Array(9);
      q[at] = v;
      const frame = encodeFrame({ key: true, seq: 1, step: 1e-5, maxError: 1e-5, nverts: 3, q, modes: [0] }).bytes;
      if (good) assert.equal(new StrandDecoder().decode(frame).positions[at], Math.fround(v * 1e-5));
      else rejects(withHeldKey(), frame, /decoded coordinate out of range/);
    }
  }
  // a delta whose moved root is clamped, then a residual pushing it out of range
  const kq = Int32Array.from([lim, -lim, 5, lim, -lim, 6]);
  const dec = new StrandDecoder();
  dec.decode(encodeFrame({ key: true, seq: 1, step: 1e-5, maxError: 1e-5, nverts: 2, q: kq, modes: [0] }).bytes);
  const motion = { rho: [16384, 0, 0, 0, 16384, 0, 0, 0, 16384], t: [1000, -1000, 0] };
  const keep = encodeFrame({ key: false, seq: 2, refSeq: 1, step: 1e-5, maxError: 1e-5, nverts: 2, q: kq, keyQ: kq, motion, modes: [0] });
  assert.equal(dec.decode(keep.bytes).positions[0], Math.fround(lim * 1e-5));
  const out = Int32Array.from(kq);
  out[3] = lim + 1;
  rejects(dec, encodeFrame({ key: false, seq: 3, refSeq: 1, step: 1e-5, maxError: 1e-5, nverts: 2, q: out, keyQ: kq, motion, modes: [0] }).bytes,
    /decoded coordinate out of range/);
});

test('modes out of range and symbols of unused tables are refused', () => {
  const dec = withHeldKey();
  // keyframes allow modes 0..2
  rejects(dec, smallKey({ modes: Array.from({ length: 11 }, (_, j) => (j === 9 ? 3 : 0)) }).bytes, /prediction mode out of range/);
  // the mode table listed as unused; then a vertex table
  const base = smallKey();
  const tables = Array.from(base.bytes.subarray(base.tablesAt, base.ransLenAt));
  rejects(dec, encodeFrame({ key: true, seq: 1, step: 1.9375e-4, maxError: 1e-4, nverts: 5, q: lattice(11, 5, 4242, true),
    modes: Array.from({ length: 11 }, (_, j) => j % 3), tableBytes: [0, ...tables.slice(tableLength(tables, 0))] }).bytes,
  /a symbol from an unused probability table/);
  const rootAt = tableLength(tables, 0);
  rejects(dec, encodeFrame({ key: true, seq: 1, step: 1.9375e-4, maxError: 1e-4, nverts: 5, q: lattice(11, 5, 4242, true),
    modes: Array.from({ length: 11 }, (_, j) => j % 3),
    tableBytes: [...tables.slice(0, rootAt), 0, ...tables.slice(rootAt + tableLength(tables, rootAt))] }).bytes,
  /a symbol from an unused probability table/);
});

// The length in bytes of the table at tables[at] (count, then gap/freq varints).
function tableLength(tables, at) {
  let p = at;
  const varint = () => { const b = tables[p++]; if (b & 128) p++; return b & 128 ? (b & 127) | (tables[p - 1] << 7) : b; };
  const n = varint();
  for (let k = 0; k < 2 * n; k++) varint();
  return p - at;
}

test('malformed probability tables are refused', () => {
  const dec = withHeldKey();
  const f = { key: true, seq: 1, step: 1.9375e-4, maxError: 1e-4, nverts: 2, q: new Int32Array(6), modes: [0] };
  const rest = [0, 0, 0, 0, 0, 0, 0, 0]; // tables 1..8 unused
  const cases = [
    [[1, 0, 0xff, 0x1f, ...rest], /frequencies sum to 4095, not 4096/],
    [[2, 0, 0x80, 0x20, 0, 1, ...rest], /frequency 1 invalid/],
    [[1, 0, 0, ...rest], /frequency 0 invalid/],
    [[1, 0xd7, 0x02, 0x80, 0x20, ...rest], /names a symbol beyond 342/],
    [[0xd8, 0x02, ...rest], /lists 344 symbols/],
    [[1, 0, 0x80, 0xa0, 0x01, ...rest], /oversized value/],
  ];
  for (const [tableBytes, pattern] of cases) rejects(dec, encodeFrame({ ...f, tableBytes }).bytes, pattern);
  // tables that end with the frame
  for (const cut of [[1, 0, 0x80], [1], [2, 0, 0x80, 0x10, 3]]) {
    const e = encodeFrame({ ...f, tableBytes: cut });
    const c = e.bytes.slice(0, e.ransLenAt);
    new DataView(c.buffer).setUint32(60, c.length - HEADER_SIZE, true);
    stampCrc(c);
    rejects(dec, c, /truncated probability tables/);
  }
  // a mode table may list any symbol below 343 (only decoding an invalid mode is an error)
  const wide = encodeFrame({ ...f, tableBytes: [2, 0, 0x80, 0x10, 0xd5, 0x02, 0x80, 0x10, 1, 0, 0x80, 0x20, ...rest.slice(1)] });
  assert.throws(() => dec.decode(wide.bytes), (e) => !/probability tables|table \d/.test(e.message));
});

test('the modes vectors are what the reference encoder makes and decode to float32(q step)', () => {
  const write = process.env.STRANDCAST_WRITE_VECTORS === '1';
  for (const [ns, nv] of MODE_SHAPES) {
    const dec = new StrandDecoder();
    for (const f of modeStream(ns, nv)) {
      const want = Float32Array.from(f.q, (q) => q * MODE_STEP);
      const wantBytes = new Uint8Array(want.buffer);
      if (write) {
        writeFileSync(join(vdir, f.name + '.bin'), f.bytes);
        writeFileSync(join(vdir, f.name + '.out.f32'), wantBytes);
      }
      assert.deepEqual(load(f.name + '.bin'), f.bytes, `${f.name}.bin differs from what the reference encoder makes`);
      sameBits(dec.decode(f.bytes).positions, f.name + '.out.f32');
    }
  }
});

test('peekHeader reads the fixed header', () => {
  const h = peekHeader(keyBytes());
  assert.equal(h.keyframe, true);
  assert.equal(h.seq, 1000);
  assert.equal(h.simStep, basic.frames[0].sim_step);
  assert.deepEqual([...h.headOrientation], basic.frames[0].head_orientation.map(Math.fround));
  assert.equal(h.nverts, basic.nverts);
  assert.ok(h.step > 0 && h.step <= 2 * h.maxError);
});

test('crc32 matches the bitwise CRC at every length, offset and split', () => {
  const next = rng(777);
  const big = new Uint8Array(300);
  for (let i = 0; i < big.length; i++) big[i] = next() & 0xff;
  for (let off = 0; off < 9; off++) {
    for (let len = 0; len + off <= 41; len++) {
      const want = crc32(big.subarray(off, off + len));
      assert.equal(codecCrc32(big, off, off + len, 0), want, `offset ${off} length ${len}`);
      assert.equal(codecCrc32(big.subarray(off, off + len), 0, len, 0), want);
      const cut = len >> 1; // continued: the tail after a prefix
      assert.equal(codecCrc32(big, off + cut, off + len, codecCrc32(big, off, off + cut, 0)), want);
    }
  }
  assert.equal(codecCrc32(big, 0, big.length, 0), crc32(big));
  assert.equal(codecCrc32(new TextEncoder().encode('123456789'), 0, 9, 0), 0xcbf43926); // the CRC-32 check value
});

test('a frame decodes the same at any byte offset of its buffer', () => {
  const key = keyBytes(), delta = deltaBytes();
  for (let off = 0; off < 8; off++) {
    const dec = new StrandDecoder();
    for (const [bytes, f] of [[key, basic.frames[0]], [delta, basic.frames[1]]]) {
      const buf = new Uint8Array(bytes.length + 16).fill(0xa5);
      buf.set(bytes, off);
      sameBits(dec.decode(buf.subarray(off, off + bytes.length)).positions, f.file + '.out.f32');
    }
  }
});

test('a larger frame that fails keeps the held keyframe while the heap grows', () => {
  const small = manifest.streams.find((s) => s.nstrands_sent * s.nverts < basic.nstrands_sent * basic.nverts);
  assert.ok(small, 'a stream smaller than basic');
  const dec = new StrandDecoder();
  dec.decode(load(small.frames[0].file + '.bin'));
  const bad = keyBytes();
  bad[HEADER_SIZE] ^= 0x7f; // the mode table's symbol count
  restampCrc(bad);
  assert.throws(() => dec.decode(bad), /^Error: codec: /);
  assert.equal(dec.keySeq, small.frames[0].seq);
  const d = small.frames.find((f) => !f.keyframe);
  sameBits(dec.decode(load(d.file + '.bin')).positions, d.file + '.out.f32');
  sameBits(dec.decode(keyBytes()).positions, basic.frames[0].file + '.out.f32'); // and the larger stream now
});

test('a group that reads as far as a corrupt frame can is refused with a codec error', () => {
  // 8 strands of 4096 vertices whose every residual is an escape of exponent 28 (34 raw bits an
  // axis); then the same frame with its raw bits cut to 8 bytes: the first group reads on past
  // the cut (through zeros, or the whole frame's bits left in the core's memory) until an
  // escape field or the check after the group refuses the frame (a read outside the memory
  // would be a RuntimeError; coreLayout's READ_SLACK is checked below)
  const ns = 8, nverts = 4096, x = (1 << 26) - 1;
  const q = new Int32Array(ns * nverts * 3);
  for (let i = 0; i < q.length; i++) q[i] = (Math.floor(i / 3) % nverts) % 2 ? x : -x;
  const f = encodeFrame({ key: true, seq: 1, step: 1e-5, maxError: 1e-5, nverts, q, modes: new Array(ns).fill(0) });
  const dec = new StrandDecoder();
  const out = dec.decode(f.bytes).positions;
  q.forEach((v, i) => assert.equal(out[i], Math.fround(v * 1e-5)));
  const cut = f.bytes.slice(0, f.bitsAt + 8);
  new DataView(cut.buffer).setUint32(60, cut.length - HEADER_SIZE, true);
  stampCrc(cut);
  rejects(dec, cut, /^Error: codec: (raw bit stream is 64 bits, frame used \d+|corrupt raw bits)/);
  rejects(new StrandDecoder(), cut, /^Error: codec: raw bit stream is 64 bits, frame used \d+/);
});

test('the decoder\'s memory regions are disjoint and leave the read slack after the frame', () => {
  for (const [ns, nverts, cap] of [[1, 2, 1], [24, 12, 65536], [4096, 32, 120000], [32768, 32, 1 << 20], [4097, 4096, 1 << 26]]) {
    const nq = 3 * ns * nverts, seg = Math.ceil(ns / 8) * 32 * nverts, heap = 1 << 20;
    const l = coreLayout(heap, nq, seg, cap);
    assert.ok(l.q[0] >= heap && l.q[1] === l.q[0] + 4 * nq && l.d[0] >= l.q[1] + 4 * nq && l.d[0] % 16 === 0);
    assert.ok(l.d[1] >= l.d[0] + 2 * seg && l.out[0] >= l.d[1] + 2 * seg && l.out[1] === l.out[0] + 4 * nq);
    assert.ok(l.bytes === l.out[1] + 4 * nq && l.end >= l.bytes + cap + 16 + 120 * 4096 + 64);
    assert.ok(READ_SLACK >= 120 * 4096 + 64);
  }
});

test('the core module imports only its memory and exports the core', () => {
  const bytes = Uint8Array.from(atob(KERNEL_WASM), (c) => c.charCodeAt(0));
  const mod = new WebAssembly.Module(bytes);
  assert.deepEqual(WebAssembly.Module.imports(mod), [{ module: 'env', name: 'memory', kind: 'memory' }]);
  const names = WebAssembly.Module.exports(mod).map((e) => e.name).sort();
  assert.deepEqual(names, ['__heap_base', 'codec_core_check', 'codec_core_crc32', 'codec_core_decode',
    'codec_core_header', 'codec_core_init', 'codec_core_regions', 'codec_core_reset', 'codec_core_seg_len',
    'codec_core_size']);
  const k = new WebAssembly.Instance(mod, { env: { memory: new WebAssembly.Memory({ initial: 2 }) } }).exports;
  assert.ok(k.__heap_base.value >= 65536 && k.__heap_base.value < 2 * 65536, `heap base ${k.__heap_base.value}`);
  assert.equal(k.codec_core_seg_len(9, 3), 2 * 32 * 3);
});

test('hair mesh frames: every column is sent, and a delta needs a keyframe of its own codec', () => {
  const s = manifest.streams.find((m) => m.codec === CODEC_ID_HAIRMESH);
  const key = load(s.frames[0].file + '.bin'), delta = load(s.frames[1].file + '.bin');
  assert.equal(peekHeader(key).codec, CODEC_ID_HAIRMESH);
  const strided = key.slice();
  const dv = new DataView(strided.buffer);
  dv.setUint32(56, 2, true);
  dv.setUint32(48, Math.ceil(s.nstrands / 2), true);
  restampCrc(strided);
  assert.throws(() => peekHeader(strided), /^Error: codec: a hair mesh frame has stride 1, not 2 \[stride \/ nstrands_total, byte 56\]$/);
  rejects(new StrandDecoder(), strided, /a hair mesh frame has stride 1, not 2/);
  const asStrands = key.slice();
  asStrands[6] = CODEC_ID_STRAND;
  restampCrc(asStrands);
  const dec = new StrandDecoder();
  assert.equal(dec.decode(asStrands).codec, CODEC_ID_STRAND);
  rejects(dec, delta, /does not match its keyframe's layout or step/);
  assert.equal(dec.decode(key).codec, CODEC_ID_HAIRMESH);
  sameBits(dec.decode(delta).positions, s.frames[1].file + '.out.f32');
});
