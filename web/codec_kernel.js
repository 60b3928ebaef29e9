// Strand frame decoding kernel (proto/CODEC.md): entropy decoding, prediction and dequantization
// of one frame, written in asm.js (so that engines which compile asm.js run it as native code;
// elsewhere it is plain JavaScript with the same results).

// Heap layout (byte offsets). The tables and scratch below K_KEY are fixed; the lattice and
// output regions follow (kernelLayout).
export const K_FREQ = 0;         // Int32 [10 * 512]: per table and symbol key (below), freq << 12 | start
export const K_INFO = 20480;     // Uint16 [10 * 4096]: per table and slot, the symbol's INFO entry
export const K_RES = 102400;     // Int32 [192]: residual of class c from raw bits b at c << 5 | (b & 31)
export const K_MOTION = 103168;  // Float64 [12]: r0..r8, then t + 2^30 + 1/2 per axis (deltas)
export const K_STATE = 103264;   // Int32 [4]: x0, x1, rpos, bit position after the frame
export const K_RESID = 131072;   // Int32 [3 * 4096]: one strand's residuals
export const K_MOVED = 180224;   // Int32 [6]: the first two vertices of a strand of the moved keyframe
export const K_ZERO = 180288;    // Int32 [6]: zeros (the first keyframe strand's missing neighbour)
export const K_KEY = 196608;     // start of the lattice regions (kernelLayout)

// INFO entries: vertex tables (1..8): c0 | c1 << 3 | c2 << 6 (the residual classes, which name
// the symbol), the next vertex's table << 9, INFO_SLOW (an escaped axis); the mode and escape
// tables: the symbol; every slot of an unused table: INFO_UNUSED. A symbol's key in K_FREQ is
// its INFO entry & 511.
export const INFO_SLOW = 1 << 13;
export const INFO_UNUSED = 0xffff;

// Kernel result codes.
export const K_OK = 0;
export const K_BAD_STREAM = -1; // invalid symbol or stream overrun
export const K_BAD_VALUE = -2;  // decoded coordinate out of range

/**
 * Region offsets for frames of nq lattice coordinates whose bytes need frameCap bytes: the held
 * keyframe's and the current frame's lattice (Int32), the output (Float32), the frame's bytes,
 * and the heap size (a size asm.js accepts: a power of two up to 2^24, else a multiple of 2^24).
 */
export function kernelLayout(nq, frameCap) {
  const key = K_KEY, cur = key + 4 * nq, out = cur + 4 * nq, bytes = out + 4 * nq;
  const need = bytes + frameCap;
  let size = 1 << 19;
  while (size < need && size < 1 << 24) size *= 2;
  if (size < need) size = Math.ceil(need / (1 << 24)) * (1 << 24);
  return { key, cur, out, bytes, size };
}

/**
 * Links the kernel to `heap` (an ArrayBuffer of kernelLayout's size). Returns { frame }, where
 * frame(key, ns, per, x0, x1, rpos, rend, bstart, bend, keyOff, curOff, outOff, step) decodes
 * the ns strands (per = 3 * nverts coordinates each) of a frame whose bytes lie in the heap:
 * the rANS stream from rpos (after the initial states x0, x1) to rend, the raw bits from bstart
 * to bend (byte offsets). The tables (K_FREQ, K_INFO, K_RES) and for a delta the motion
 * (K_MOTION) must be filled in. It writes float32(q * step) to outOff; a keyframe writes its
 * lattice coordinates to curOff (Int32, where each strand reads the previous one), a delta
 * reads the held keyframe's at keyOff and uses curOff as scratch. It leaves the reader state in
 * K_STATE and returns K_OK, or a negative K_BAD_* code at the first error. Runs on the
 * caller's thread; owns nothing.
 */
export function CodecKernel(stdlib, foreign, heap) {
  'use asm';
  // asm.js takes literals only: the fixed regions appear below as byte offsets (K_FREQ 0,
  // K_INFO 20480, K_RES 102400, K_RESID 131072, K_MOVED 180224, K_ZERO 180288) and as element
  // indices (K_MOTION: F64[12896..12907], K_STATE: I32[25816..25819], K_MOVED: I32[45056..]);
  // 4608 is table 9 (escapes) << 9 in K_FREQ.
  var U8 = new stdlib.Uint8Array(heap);
  var U16 = new stdlib.Uint16Array(heap);
  var I32 = new stdlib.Int32Array(heap);
  var F32 = new stdlib.Float32Array(heap);
  var F64 = new stdlib.Float64Array(heap);
  var imul = stdlib.Math.imul;
  // the entropy reader between strands: rANS states (x0 codes the next symbol), rANS byte
  // position, raw bit position (from the bit stream's start)
  var gx0 = 0, gx1 = 0, grpos = 0, gbp = 0;
  // the previous delta strand's root, in this frame and in the moved keyframe
  var gn0 = 0, gn1 = 0, gn2 = 0, gkn0 = 0, gkn1 = 0, gkn2 = 0;

  // The raw bits from bit bp of the stream at byte bstart on (at least 25 of them), least
  // significant first; bytes at and past bend read as zeros.
  function bitsAt(bstart, bp, bend) {
    bstart = bstart | 0;
    bp = bp | 0;
    bend = bend | 0;
    var p = 0, k = 0, w = 0;
    p = (bstart + (bp >> 3)) | 0;
    for (k = 0; (k | 0) < 4; k = (k + 1) | 0) {
      if (((p + k) | 0) < (bend | 0)) w = w | (U8[(p + k) | 0] << (k << 3));
    }
    return (w >>> (bp & 7)) | 0;
  }

  // One strand's symbols: returns its mode (below nmodes) and leaves the residuals of its per
  // coordinates in K_RESID; -1 on an invalid symbol or a stream overrun. The fast path (no
  // escape, away from the streams' ends) renormalizes without branches and reads the three raw
  // fields (at most 15 bits) from one 24-bit window.
  function symbols(per, nmodes, rend, bstart, bend) {
    per = per | 0;
    nmodes = nmodes | 0;
    rend = rend | 0;
    bstart = bstart | 0;
    bend = bend | 0;
    var x0 = 0, x1 = 0, rpos = 0, bp = 0, li = 0, mode = 0, e = 0, x = 0, n = 0, f = 0, p = 0, w = 0;
    var table = 1, pr = 0, pend = 0, rsafe = 0, bsafe = 0, c0 = 0, c1 = 0, c2 = 0;
    var ax = 0, c = 0, r = 0, ex = 0, lo = 0, mag = 0;
    x0 = gx0;
    x1 = gx1;
    rpos = grpos;
    bp = gbp;
    rsafe = (rend - 2) | 0;
    bsafe = (bend - 3) | 0;
    li = x0 & 4095;
    mode = U16[(20480 + (li << 1)) >> 1] | 0;
    if ((mode | 0) >= (nmodes | 0)) return -1; // also an unused table
    e = I32[(mode << 2) >> 2] | 0;
    x = ((imul(e >> 12, x0 >> 12) | 0) + (x0 & 4095) - (e & 4095)) | 0;
    while ((x | 0) < 8388608) {
      if ((rpos | 0) >= (rend | 0)) return -1;
      x = (x << 8) | (U8[rpos] | 0);
      rpos = (rpos + 1) | 0;
    }
    x0 = x1;
    x1 = x;
    pend = (131072 + (per << 2)) | 0;
    for (pr = 131072; (pr | 0) < (pend | 0); pr = (pr + 12) | 0) {
      li = (table << 12) | (x0 & 4095);
      f = U16[(20480 + (li << 1)) >> 1] | 0;
      e = I32[(((table << 9) | (f & 511)) << 2) >> 2] | 0;
      x = ((imul(e >> 12, x0 >> 12) | 0) + (x0 & 4095) - (e & 4095)) | 0;
      table = (f >> 9) & 15;
      p = (bstart + (bp >> 3)) | 0;
      if ((((f & 8192) == 0) & ((rpos | 0) <= (rsafe | 0)) & ((p | 0) <= (bsafe | 0))) != 0) {
        n = ((((x - 8388608) | 0) >>> 31) + (((x - 32768) | 0) >>> 31)) | 0;
        x = (x << (n << 3)) | ((((U8[rpos] | 0) << 8) | (U8[(rpos + 1) | 0] | 0)) >> ((2 - n) << 3));
        rpos = (rpos + n) | 0;
        x0 = x1;
        x1 = x;
        w = ((U8[p] | 0) | ((U8[(p + 1) | 0] | 0) << 8) | ((U8[(p + 2) | 0] | 0) << 16)) >> (bp & 7);
        c0 = f & 7;
        c1 = (f >> 3) & 7;
        c2 = (f >> 6) & 7;
        I32[pr >> 2] = I32[(102400 + (((c0 << 5) | (w & 31)) << 2)) >> 2];
        w = w >> c0;
        I32[(pr + 4) >> 2] = I32[(102400 + (((c1 << 5) | (w & 31)) << 2)) >> 2];
        I32[(pr + 8) >> 2] = I32[(102400 + (((c2 << 5) | ((w >> c1) & 31)) << 2)) >> 2];
        bp = (bp + c0 + c1 + c2) | 0;
        continue;
      }
      // the general path: an unused table, an escaped axis, or near a stream's end
      if ((f | 0) == 65535) return -1;
      while ((x | 0) < 8388608) {
        if ((rpos | 0) >= (rend | 0)) return -1;
        x = (x << 8) | (U8[rpos] | 0);
        rpos = (rpos + 1) | 0;
      }
      x0 = x1;
      x1 = x;
      for (ax = 0; (ax | 0) < 3; ax = (ax + 1) | 0) {
        c = (f >> ((ax * 3) | 0)) & 7;
        if ((c | 0) < 6) {
          r = I32[(102400 + (((c << 5) | ((bitsAt(bstart, bp, bend) | 0) & 31)) << 2)) >> 2] | 0;
          bp = (bp + c) | 0;
        } else {
          // escape: e - 5 from the escape table, then the sign and e bits below the leading one
          li = 36864 | (x0 & 4095);
          ex = U16[(20480 + (li << 1)) >> 1] | 0;
          if ((ex | 0) >= 25) return -1; // also an unused table
          e = I32[((4608 | ex) << 2) >> 2] | 0;
          x = ((imul(e >> 12, x0 >> 12) | 0) + (x0 & 4095) - (e & 4095)) | 0;
          while ((x | 0) < 8388608) {
            if ((rpos | 0) >= (rend | 0)) return -1;
            x = (x << 8) | (U8[rpos] | 0);
            rpos = (rpos + 1) | 0;
          }
          x0 = x1;
          x1 = x;
          ex = (ex + 5) | 0;
          lo = ((ex | 0) > 16) ? 16 : ex;
          w = bitsAt(bstart, bp, bend) | 0;
          mag = (1 << ex) | ((w >> 1) & ((1 << lo) - 1));
          bp = (bp + 1 + lo) | 0;
          if ((ex | 0) > (lo | 0)) {
            mag = mag | (((bitsAt(bstart, bp, bend) | 0) & ((1 << (ex - lo)) - 1)) << lo);
            bp = (bp + ex - lo) | 0;
          }
          r = (w & 1) ? ((0 - mag) | 0) : mag;
        }
        I32[(pr + (ax << 2)) >> 2] = r;
      }
    }
    gx0 = x0;
    gx1 = x1;
    grpos = rpos;
    gbp = bp;
    return mode | 0;
  }

  // K_MOVED[0, 6) = the first two vertices of the held keyframe's strand at pk moved by the
  // rigid motion (K_MOTION; see moved in rebuildDelta).
  function moveTwo(pk) {
    pk = pk | 0;
    var m0 = 0.0, m1 = 0.0, m2 = 0.0, m3 = 0.0, m4 = 0.0, m5 = 0.0, m6 = 0.0, m7 = 0.0, m8 = 0.0;
    var t0 = 0.0, t1 = 0.0, t2 = 0.0, kx = 0.0, ky = 0.0, kz = 0.0;
    var pw = 0, w0 = 0, w1 = 0, w2 = 0;
    m0 = +F64[12896]; m1 = +F64[12897]; m2 = +F64[12898]; m3 = +F64[12899]; m4 = +F64[12900];
    m5 = +F64[12901]; m6 = +F64[12902]; m7 = +F64[12903]; m8 = +F64[12904];
    t0 = +F64[12905]; t1 = +F64[12906]; t2 = +F64[12907];
    for (pw = 180224; (pw | 0) < 180248; pw = (pw + 12) | 0, pk = (pk + 12) | 0) {
      kx = +(I32[pk >> 2] | 0);
      ky = +(I32[(pk + 4) >> 2] | 0);
      kz = +(I32[(pk + 8) >> 2] | 0);
      w0 = ((~~(m0 * kx + m1 * ky + m2 * kz + t0)) - 1073741824) | 0;
      w1 = ((~~(m3 * kx + m4 * ky + m5 * kz + t1)) - 1073741824) | 0;
      w2 = ((~~(m6 * kx + m7 * ky + m8 * kz + t2)) - 1073741824) | 0;
      if (((w0 + 67108863) | (67108863 - w0) | (w1 + 67108863) | (67108863 - w1) |
           (w2 + 67108863) | (67108863 - w2)) < 0) {
        w0 = ((w0 | 0) < -67108863) ? -67108863 : ((w0 | 0) > 67108863) ? 67108863 : w0;
        w1 = ((w1 | 0) < -67108863) ? -67108863 : ((w1 | 0) > 67108863) ? 67108863 : w1;
        w2 = ((w2 | 0) < -67108863) ? -67108863 : ((w2 | 0) > 67108863) ? 67108863 : w2;
      }
      I32[pw >> 2] = w0;
      I32[(pw + 4) >> 2] = w1;
      I32[(pw + 8) >> 2] = w2;
    }
  }

  // The vertices from pc (lattice, Int32) / po (output) / pr (residuals) up to pend with the
  // linear prediction 2 P[v-1] - P[v-2] (kind 3), or (kind 4) that for the first and then the
  // smooth linear P[v-1] + (P[v-1] - P[v-3]) / 2 rounded half to even; a, b: P[v-1], P[v-2].
  // Returns bad OR'ed with the range checks.
  function linear(kind, pc, po, pr, pend, a0, a1, a2, b0, b1, b2, step, bad) {
    kind = kind | 0;
    pc = pc | 0;
    po = po | 0;
    pr = pr | 0;
    pend = pend | 0;
    a0 = a0 | 0;
    a1 = a1 | 0;
    a2 = a2 | 0;
    b0 = b0 | 0;
    b1 = b1 | 0;
    b2 = b2 | 0;
    step = +step;
    bad = bad | 0;
    var q0 = 0, q1 = 0, q2 = 0, c0 = 0, c1 = 0, c2 = 0;
    if (((kind | 0) == 4) & ((pc | 0) < (pend | 0))) {
      q0 = (a0 + a0 - b0 + (I32[pr >> 2] | 0)) | 0;
      q1 = (a1 + a1 - b1 + (I32[(pr + 4) >> 2] | 0)) | 0;
      q2 = (a2 + a2 - b2 + (I32[(pr + 8) >> 2] | 0)) | 0;
      bad = bad | (q0 + 67108863) | (67108863 - q0) | (q1 + 67108863) | (67108863 - q1) |
        (q2 + 67108863) | (67108863 - q2);
      I32[pc >> 2] = q0;
      I32[(pc + 4) >> 2] = q1;
      I32[(pc + 8) >> 2] = q2;
      F32[po >> 2] = +(q0 | 0) * step;
      F32[(po + 4) >> 2] = +(q1 | 0) * step;
      F32[(po + 8) >> 2] = +(q2 | 0) * step;
      c0 = b0; c1 = b1; c2 = b2;
      b0 = a0; b1 = a1; b2 = a2;
      a0 = q0; a1 = q1; a2 = q2;
      for (pc = (pc + 12) | 0, po = (po + 12) | 0, pr = (pr + 12) | 0; (pc | 0) < (pend | 0);
        pc = (pc + 12) | 0, po = (po + 12) | 0, pr = (pr + 12) | 0) {
        q0 = (a0 - c0) | 0;
        q0 = (a0 + ((q0 + ((q0 >> 1) & 1)) >> 1) + (I32[pr >> 2] | 0)) | 0;
        q1 = (a1 - c1) | 0;
        q1 = (a1 + ((q1 + ((q1 >> 1) & 1)) >> 1) + (I32[(pr + 4) >> 2] | 0)) | 0;
        q2 = (a2 - c2) | 0;
        q2 = (a2 + ((q2 + ((q2 >> 1) & 1)) >> 1) + (I32[(pr + 8) >> 2] | 0)) | 0;
        bad = bad | (q0 + 67108863) | (67108863 - q0) | (q1 + 67108863) | (67108863 - q1) |
          (q2 + 67108863) | (67108863 - q2);
        I32[pc >> 2] = q0;
        I32[(pc + 4) >> 2] = q1;
        I32[(pc + 8) >> 2] = q2;
        F32[po >> 2] = +(q0 | 0) * step;
        F32[(po + 4) >> 2] = +(q1 | 0) * step;
        F32[(po + 8) >> 2] = +(q2 | 0) * step;
        c0 = b0; c1 = b1; c2 = b2;
        b0 = a0; b1 = a1; b2 = a2;
        a0 = q0; a1 = q1; a2 = q2;
      }
      return bad | 0;
    }
    for (; (pc | 0) < (pend | 0); pc = (pc + 12) | 0, po = (po + 12) | 0, pr = (pr + 12) | 0) {
      q0 = (a0 + a0 - b0 + (I32[pr >> 2] | 0)) | 0;
      q1 = (a1 + a1 - b1 + (I32[(pr + 4) >> 2] | 0)) | 0;
      q2 = (a2 + a2 - b2 + (I32[(pr + 8) >> 2] | 0)) | 0;
      bad = bad | (q0 + 67108863) | (67108863 - q0) | (q1 + 67108863) | (67108863 - q1) |
        (q2 + 67108863) | (67108863 - q2);
      I32[pc >> 2] = q0;
      I32[(pc + 4) >> 2] = q1;
      I32[(pc + 8) >> 2] = q2;
      F32[po >> 2] = +(q0 | 0) * step;
      F32[(po + 4) >> 2] = +(q1 | 0) * step;
      F32[(po + 8) >> 2] = +(q2 | 0) * step;
      b0 = a0; b1 = a1; b2 = a2;
      a0 = q0; a1 = q1; a2 = q2;
    }
    return bad | 0;
  }

  // Rebuilds keyframe strand j (mode < 3) from its residuals (K_RESID): the lattice coordinates
  // to pc (per of them), float32(q * step) to po. The neighbour N is the previous strand (at
  // pc - per), zeros (K_ZERO) for the first: root N[0] + R; vertex 1 P[0] + N[1] - N[0];
  // from vertex 2 mode 1 (with a neighbour) P[v-1] + N[v] - N[v-1], mode 2 smooth linear,
  // else linear. Returns the OR of the range checks (negative: a coordinate out of range).
  function rebuildKey(mode, j, pc, po, per, step) {
    mode = mode | 0;
    j = j | 0;
    pc = pc | 0;
    po = po | 0;
    per = per | 0;
    step = +step;
    var pn = 0, pr = 131072, pend = 0, bad = 0, a0 = 0, a1 = 0, a2 = 0, b0 = 0, b1 = 0, b2 = 0;
    var n0 = 0, n1 = 0, n2 = 0, k0 = 0, k1 = 0, k2 = 0;
    pend = (pc + (per << 2)) | 0;
    pn = ((j | 0) > 0) ? ((pc - (per << 2)) | 0) : 180288;
    k0 = I32[pn >> 2] | 0;
    k1 = I32[(pn + 4) >> 2] | 0;
    k2 = I32[(pn + 8) >> 2] | 0;
    b0 = (k0 + (I32[pr >> 2] | 0)) | 0;
    b1 = (k1 + (I32[(pr + 4) >> 2] | 0)) | 0;
    b2 = (k2 + (I32[(pr + 8) >> 2] | 0)) | 0;
    n0 = I32[(pn + 12) >> 2] | 0;
    n1 = I32[(pn + 16) >> 2] | 0;
    n2 = I32[(pn + 20) >> 2] | 0;
    a0 = (b0 + n0 - k0 + (I32[(pr + 12) >> 2] | 0)) | 0;
    a1 = (b1 + n1 - k1 + (I32[(pr + 16) >> 2] | 0)) | 0;
    a2 = (b2 + n2 - k2 + (I32[(pr + 20) >> 2] | 0)) | 0;
    bad = (b0 + 67108863) | (67108863 - b0) | (b1 + 67108863) | (67108863 - b1) | (b2 + 67108863) |
      (67108863 - b2) | (a0 + 67108863) | (67108863 - a0) | (a1 + 67108863) | (67108863 - a1) |
      (a2 + 67108863) | (67108863 - a2);
    I32[pc >> 2] = b0;
    I32[(pc + 4) >> 2] = b1;
    I32[(pc + 8) >> 2] = b2;
    I32[(pc + 12) >> 2] = a0;
    I32[(pc + 16) >> 2] = a1;
    I32[(pc + 20) >> 2] = a2;
    F32[po >> 2] = +(b0 | 0) * step;
    F32[(po + 4) >> 2] = +(b1 | 0) * step;
    F32[(po + 8) >> 2] = +(b2 | 0) * step;
    F32[(po + 12) >> 2] = +(a0 | 0) * step;
    F32[(po + 16) >> 2] = +(a1 | 0) * step;
    F32[(po + 20) >> 2] = +(a2 | 0) * step;
    pc = (pc + 24) | 0;
    po = (po + 24) | 0;
    pr = (pr + 24) | 0;
    pn = (pn + 24) | 0;
    if (((mode | 0) != 1) | ((j | 0) == 0)) {
      return linear(((mode | 0) == 2) ? 4 : 3, pc, po, pr, pend, a0, a1, a2, b0, b1, b2, step, bad) | 0;
    }
    for (; (pc | 0) < (pend | 0); pc = (pc + 12) | 0, po = (po + 12) | 0, pr = (pr + 12) | 0, pn = (pn + 12) | 0) {
      k0 = n0;
      k1 = n1;
      k2 = n2;
      n0 = I32[pn >> 2] | 0;
      n1 = I32[(pn + 4) >> 2] | 0;
      n2 = I32[(pn + 8) >> 2] | 0;
      a0 = (a0 + n0 - k0 + (I32[pr >> 2] | 0)) | 0;
      a1 = (a1 + n1 - k1 + (I32[(pr + 4) >> 2] | 0)) | 0;
      a2 = (a2 + n2 - k2 + (I32[(pr + 8) >> 2] | 0)) | 0;
      bad = bad | (a0 + 67108863) | (67108863 - a0) | (a1 + 67108863) | (67108863 - a1) |
        (a2 + 67108863) | (67108863 - a2);
      I32[pc >> 2] = a0;
      I32[(pc + 4) >> 2] = a1;
      I32[(pc + 8) >> 2] = a2;
      F32[po >> 2] = +(a0 | 0) * step;
      F32[(po + 4) >> 2] = +(a1 | 0) * step;
      F32[(po + 8) >> 2] = +(a2 | 0) * step;
    }
    return bad | 0;
  }

  // Rebuilds delta strand j (mode < 4) from its residuals (K_RESID) and the held keyframe's
  // strand at pk moved by the rigid motion (K' = the moved keyframe: trunc(r.k + t + 2^30 + 1/2)
  // - 2^30 in binary64 from left to right, the sum in (0, 2^31) as |r| <= 2, |k| < 2^26,
  // |t| <= 2^28; clamped to |K'| < 2^26): float32(q * step) to po; the lattice coordinates
  // are kept (at pc) only where a later vertex of linear modes reads them. Root: K'[0] + R,
  // moved like the previous strand's root (gn, gkn: its root in this frame and in K', which
  // this strand's root replaces); vertex 1 P[0] + K'[1] - K'[0]; from vertex 2 mode 0 the same,
  // mode 1 that plus P[v-1] - K'[v-1] - P[v-2] + K'[v-2], mode 2 linear, mode 3 linear then
  // smooth linear. Returns the OR of the range checks.
  function rebuildDelta(mode, j, pc, po, pk, per, step) {
    mode = mode | 0;
    j = j | 0;
    pc = pc | 0;
    po = po | 0;
    pk = pk | 0;
    per = per | 0;
    step = +step;
    var m0 = 0.0, m1 = 0.0, m2 = 0.0, m3 = 0.0, m4 = 0.0, m5 = 0.0, m6 = 0.0, m7 = 0.0, m8 = 0.0;
    var t0 = 0.0, t1 = 0.0, t2 = 0.0, kx = 0.0, ky = 0.0, kz = 0.0;
    var pr = 131072, pend = 0, bad = 0, a0 = 0, a1 = 0, a2 = 0, b0 = 0, b1 = 0, b2 = 0, q0 = 0, q1 = 0, q2 = 0;
    var w0 = 0, w1 = 0, w2 = 0, k0 = 0, k1 = 0, k2 = 0, l0 = 0, l1 = 0, l2 = 0;
    pend = (pc + (per << 2)) | 0;
    moveTwo(pk);
    l0 = I32[45056] | 0;
    l1 = I32[45057] | 0;
    l2 = I32[45058] | 0;
    k0 = I32[45059] | 0;
    k1 = I32[45060] | 0;
    k2 = I32[45061] | 0;
    b0 = (l0 + (I32[pr >> 2] | 0)) | 0;
    b1 = (l1 + (I32[(pr + 4) >> 2] | 0)) | 0;
    b2 = (l2 + (I32[(pr + 8) >> 2] | 0)) | 0;
    if ((j | 0) > 0) {
      b0 = (b0 + gn0 - gkn0) | 0;
      b1 = (b1 + gn1 - gkn1) | 0;
      b2 = (b2 + gn2 - gkn2) | 0;
    }
    gn0 = b0; gn1 = b1; gn2 = b2;
    gkn0 = l0; gkn1 = l1; gkn2 = l2;
    a0 = (b0 + k0 - l0 + (I32[(pr + 12) >> 2] | 0)) | 0;
    a1 = (b1 + k1 - l1 + (I32[(pr + 16) >> 2] | 0)) | 0;
    a2 = (b2 + k2 - l2 + (I32[(pr + 20) >> 2] | 0)) | 0;
    bad = (b0 + 67108863) | (67108863 - b0) | (b1 + 67108863) | (67108863 - b1) | (b2 + 67108863) |
      (67108863 - b2) | (a0 + 67108863) | (67108863 - a0) | (a1 + 67108863) | (67108863 - a1) |
      (a2 + 67108863) | (67108863 - a2);
    F32[po >> 2] = +(b0 | 0) * step;
    F32[(po + 4) >> 2] = +(b1 | 0) * step;
    F32[(po + 8) >> 2] = +(b2 | 0) * step;
    F32[(po + 12) >> 2] = +(a0 | 0) * step;
    F32[(po + 16) >> 2] = +(a1 | 0) * step;
    F32[(po + 20) >> 2] = +(a2 | 0) * step;
    pc = (pc + 24) | 0;
    po = (po + 24) | 0;
    pr = (pr + 24) | 0;
    pk = (pk + 24) | 0;
    if ((mode | 0) >= 2) {
      return linear(((mode | 0) == 3) ? 4 : 3, pc, po, pr, pend, a0, a1, a2, b0, b1, b2, step, bad) | 0;
    }
    m0 = +F64[12896]; m1 = +F64[12897]; m2 = +F64[12898]; m3 = +F64[12899]; m4 = +F64[12900];
    m5 = +F64[12901]; m6 = +F64[12902]; m7 = +F64[12903]; m8 = +F64[12904];
    t0 = +F64[12905]; t1 = +F64[12906]; t2 = +F64[12907];
    if ((mode | 0) == 0) {
      pend = (po + pend - pc) | 0; // this loop keeps no lattice coordinates
      for (; (po | 0) < (pend | 0); po = (po + 12) | 0, pr = (pr + 12) | 0, pk = (pk + 12) | 0) {
        kx = +(I32[pk >> 2] | 0);
        ky = +(I32[(pk + 4) >> 2] | 0);
        kz = +(I32[(pk + 8) >> 2] | 0);
        w0 = ((~~(m0 * kx + m1 * ky + m2 * kz + t0)) - 1073741824) | 0;
        w1 = ((~~(m3 * kx + m4 * ky + m5 * kz + t1)) - 1073741824) | 0;
        w2 = ((~~(m6 * kx + m7 * ky + m8 * kz + t2)) - 1073741824) | 0;
        if (((w0 + 67108863) | (67108863 - w0) | (w1 + 67108863) | (67108863 - w1) |
             (w2 + 67108863) | (67108863 - w2)) < 0) {
          w0 = ((w0 | 0) < -67108863) ? -67108863 : ((w0 | 0) > 67108863) ? 67108863 : w0;
          w1 = ((w1 | 0) < -67108863) ? -67108863 : ((w1 | 0) > 67108863) ? 67108863 : w1;
          w2 = ((w2 | 0) < -67108863) ? -67108863 : ((w2 | 0) > 67108863) ? 67108863 : w2;
        }
        a0 = (a0 + w0 - k0 + (I32[pr >> 2] | 0)) | 0;
        a1 = (a1 + w1 - k1 + (I32[(pr + 4) >> 2] | 0)) | 0;
        a2 = (a2 + w2 - k2 + (I32[(pr + 8) >> 2] | 0)) | 0;
        bad = bad | (a0 + 67108863) | (67108863 - a0) | (a1 + 67108863) | (67108863 - a1) |
          (a2 + 67108863) | (67108863 - a2);
        F32[po >> 2] = +(a0 | 0) * step;
        F32[(po + 4) >> 2] = +(a1 | 0) * step;
        F32[(po + 8) >> 2] = +(a2 | 0) * step;
        k0 = w0; k1 = w1; k2 = w2;
      }
      return bad | 0;
    }
    for (; (pc | 0) < (pend | 0); pc = (pc + 12) | 0, po = (po + 12) | 0, pr = (pr + 12) | 0, pk = (pk + 12) | 0) {
      kx = +(I32[pk >> 2] | 0);
      ky = +(I32[(pk + 4) >> 2] | 0);
      kz = +(I32[(pk + 8) >> 2] | 0);
      w0 = ((~~(m0 * kx + m1 * ky + m2 * kz + t0)) - 1073741824) | 0;
      w1 = ((~~(m3 * kx + m4 * ky + m5 * kz + t1)) - 1073741824) | 0;
      w2 = ((~~(m6 * kx + m7 * ky + m8 * kz + t2)) - 1073741824) | 0;
      if (((w0 + 67108863) | (67108863 - w0) | (w1 + 67108863) | (67108863 - w1) |
           (w2 + 67108863) | (67108863 - w2)) < 0) {
        w0 = ((w0 | 0) < -67108863) ? -67108863 : ((w0 | 0) > 67108863) ? 67108863 : w0;
        w1 = ((w1 | 0) < -67108863) ? -67108863 : ((w1 | 0) > 67108863) ? 67108863 : w1;
        w2 = ((w2 | 0) < -67108863) ? -67108863 : ((w2 | 0) > 67108863) ? 67108863 : w2;
      }
      q0 = (a0 + w0 - k0 + a0 - k0 - b0 + l0 + (I32[pr >> 2] | 0)) | 0;
      q1 = (a1 + w1 - k1 + a1 - k1 - b1 + l1 + (I32[(pr + 4) >> 2] | 0)) | 0;
      q2 = (a2 + w2 - k2 + a2 - k2 - b2 + l2 + (I32[(pr + 8) >> 2] | 0)) | 0;
      bad = bad | (q0 + 67108863) | (67108863 - q0) | (q1 + 67108863) | (67108863 - q1) |
        (q2 + 67108863) | (67108863 - q2);
      F32[po >> 2] = +(q0 | 0) * step;
      F32[(po + 4) >> 2] = +(q1 | 0) * step;
      F32[(po + 8) >> 2] = +(q2 | 0) * step;
      b0 = a0; b1 = a1; b2 = a2;
      a0 = q0; a1 = q1; a2 = q2;
      l0 = k0; l1 = k1; l2 = k2;
      k0 = w0; k1 = w1; k2 = w2;
    }
    return bad | 0;
  }

  function frame(key, ns, per, x0, x1, rpos, rend, bstart, bend, keyOff, curOff, outOff, step) {
    key = key | 0;
    ns = ns | 0;
    per = per | 0;
    x0 = x0 | 0;
    x1 = x1 | 0;
    rpos = rpos | 0;
    rend = rend | 0;
    bstart = bstart | 0;
    bend = bend | 0;
    keyOff = keyOff | 0;
    curOff = curOff | 0;
    outOff = outOff | 0;
    step = +step;
    var j = 0, mode = 0, off = 0, per4 = 0, bad = 0;
    gx0 = x0;
    gx1 = x1;
    grpos = rpos;
    gbp = 0;
    per4 = per << 2;
    for (j = 0; (j | 0) < (ns | 0); j = (j + 1) | 0) {
      mode = symbols(per, key ? 3 : 4, rend, bstart, bend) | 0;
      if ((mode | 0) < 0) return -1;
      off = imul(j, per4) | 0;
      if (key) bad = rebuildKey(mode, j, (curOff + off) | 0, (outOff + off) | 0, per, step) | 0;
      else bad = rebuildDelta(mode, j, (curOff + off) | 0, (outOff + off) | 0, (keyOff + off) | 0, per, step) | 0;
      if ((bad | 0) < 0) return -2;
    }
    I32[25816] = gx0;
    I32[25817] = gx1;
    I32[25818] = grpos;
    I32[25819] = gbp;
    return 0;
  }

  return { frame: frame };
}
