// Tests for web/codec.js: bit-exact decoding of proto/vectors, frame skipping, and rejection of
// truncated, bit-flipped and absurd frames; the CRC, the kernel's heap (codec_kernel.js) and
// that it is valid asm.js (run with `node --test`).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawnSync } from 'node:child_process';
import { readFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

import { StrandDecoder, peekHeader, crc32 as codecCrc32, HEADER_SIZE } from '../../web/codec.js';
import { kernelLayout } from '../../web/codec_kernel.js';

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
  body.set(frame.subarray(0, 64));
  body.set(frame.subarray(HEADER_SIZE), 64);
  const c = crc32(body);
  for (let k = 0; k < 4; k++) frame[64 + k] = (c >>> (8 * k)) & 0xff;
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
  assert.equal(manifest.format_version, 1);
  assert.ok(manifest.streams.length >= 3);
  assert.ok(manifest.streams.some((s) => s.stride > 1));
});

test('every vector decodes bit for bit, in order and with frames skipped', () => {
  for (const s of manifest.streams) {
    for (const pass of [0, 1]) {
      const dec = new StrandDecoder();
      let last = null, n = 0;
      s.frames.forEach((f, idx) => {
        if (pass === 1 && !f.keyframe && idx !== s.frames.length - 1) return;
        const bytes = load(f.file + '.bin');
        assert.equal(bytes.length, f.bytes);
        const info = dec.decode(bytes);
        assert.equal(info.seq, f.seq);
        assert.equal(info.refSeq, f.ref_seq);
        assert.equal(info.keyframe, f.keyframe);
        assert.equal(info.simTime, f.sim_time);
        assert.equal(info.nstrandsSent, s.nstrands_sent);
        assert.equal(info.nstrandsTotal, s.nstrands);
        assert.equal(info.nverts, s.nverts);
        assert.equal(info.stride, s.stride);
        assert.equal(info.maxError, Math.fround(s.max_error_m));
        assert.equal(info.positions.length, s.nstrands_sent * s.nverts * 3);
        sameBits(info.positions, f.file + '.out.f32');
        if (last) assert.equal(info.positions, last, 'positions array is reused');
        last = info.positions;
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
  // a delta whose rigid motion is absurd
  const dec = new StrandDecoder();
  dec.decode(keyBytes());
  [[0, NaN], [4, 2.5], [40, -Infinity], [44, 1e30]].forEach(([off, v]) => {
    const d = deltaBytes();
    f32(d, HEADER_SIZE + off, v);
    restampCrc(d);
    assert.throws(() => dec.decode(d), /invalid rigid motion/);
  });
  dec.decode(deltaBytes());
});

test('peekHeader reads the fixed header', () => {
  const h = peekHeader(keyBytes());
  assert.equal(h.keyframe, true);
  assert.equal(h.seq, 1000);
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

test('kernel heaps have sizes asm.js accepts and hold their regions', () => {
  for (const [nq, cap] of [[6, 1], [864, 65536], [393216, 120000], [3 << 20, 1 << 20], [3 << 24, 1 << 26]]) {
    const l = kernelLayout(nq, cap);
    assert.ok(l.size >= l.bytes + cap && l.bytes === l.out + 4 * nq && l.out === l.cur + 4 * nq && l.cur === l.key + 4 * nq);
    const pow2 = (l.size & (l.size - 1)) === 0;
    assert.ok((pow2 && l.size >= 1 << 12 && l.size <= 1 << 24) || l.size % (1 << 24) === 0, `size ${l.size}`);
  }
});

test('the kernel validates as asm.js (V8 warns on stderr otherwise)', () => {
  const url = pathToFileURL(join(here, '..', '..', 'web', 'codec_kernel.js')).href;
  const code = `const k = await import(${JSON.stringify(url)});
    const l = k.kernelLayout(864, 65536);
    const f = k.CodecKernel(globalThis, null, new ArrayBuffer(l.size)).frame;
    if (typeof f !== 'function') process.exit(3);`;
  const r = spawnSync(process.execPath, ['--input-type=module', '-e', code], { encoding: 'utf8' });
  assert.equal(r.status, 0, r.stderr);
  assert.doesNotMatch(r.stderr, /asm\.js/i, r.stderr);
});
