// The "modes" test vectors (proto/vectors/modes_*): frames of every prediction mode (keyframe
// modes 0-2, delta modes 0-3, which the C encoder never writes), partial groups of 8 strands and
// escapes, made by the reference encoder (codec_encode.mjs, written from proto/CODEC.md), so that
// both builds of the decode core are checked on them (tests/test_codec.c, codec.test.mjs).
// Run `STRANDCAST_WRITE_VECTORS=1 node --test tests/js/codec.test.mjs` to write them again.

import { encodeFrame } from './codec_encode.mjs';

/** Strands x vertices of each stream (the shapes tests/test_codec.c lists too). */
export const MODE_SHAPES = [[1, 2], [3, 3], [8, 4], [13, 9], [17, 33]];
export const MODE_STEP = 1.9375e-4;
export const MODE_BOUND = Math.fround(1e-4);
const MOTION = { rho: [16380, 300, -200, -300, 16379, 150, 200, -150, 16381], t: [123, -67, 10] };

function rng(seed) {
  let s = seed >>> 0;
  return () => { s = (Math.imul(s, 1664525) + 1013904223) >>> 0; return s >>> 8; };
}

/**
 * The stream of one shape: a keyframe (strand j in mode j mod 3), then four deltas against it
 * (strand j in mode (j + m) mod 4 in delta m): [{ name, bytes, q }] with q the lattice coordinates
 * the frame codes (the decoded positions are float32(q * MODE_STEP)).
 */
export function modeStream(ns, nv) {
  const next = rng(77 + 1000 * ns + nv), n = ns * nv * 3;
  const kq = new Int32Array(n), frames = [];
  for (let j = 0; j < ns; j++) { // strands hanging from a scalp, with a few wild vertices (escapes)
    for (let v = 0; v < nv; v++) {
      for (let a = 0; a < 3; a++) {
        const base = j * 97 - 400 + (a === 1 ? -v * 180 : v * 7 * a);
        kq[(j * nv + v) * 3 + a] = base + (next() % 9) - 4 + (next() % 11 === 0 ? (next() % 4000) - 2000 : 0);
      }
    }
  }
  const common = { step: MODE_STEP, maxError: MODE_BOUND, nverts: nv };
  const keyModes = Array.from({ length: ns }, (_, j) => j % 3);
  const head = { simStep: 500, headPosition: [0.1, 1.6, -0.2], headOrientation: [0, 0.6, 0, 0.8] };
  frames.push({ q: kq, bytes: encodeFrame({ ...common, ...head, key: true, seq: 10, q: kq, modes: keyModes }).bytes });
  for (let m = 0; m < 4; m++) {
    const q = kq.map((k) => k + (next() % 61) - 30 + (next() % 13 === 0 ? (next() % 5000) - 2500 : 0));
    const modes = Array.from({ length: ns }, (_, j) => (j + m) % 4);
    const f = {
      ...common, key: false, seq: 11 + m, refSeq: 10, q, keyQ: kq, modes, motion: MOTION, simStep: 501 + m,
      headPosition: [0.1 + 0.01 * m, 1.6, -0.2], headOrientation: [0, 0.6, 0, 0.8],
    };
    frames.push({ q, bytes: encodeFrame(f).bytes });
  }
  return frames.map((f, i) => ({ ...f, name: `modes_${ns}x${nv}_${i}` }));
}
