// Catmull-Rom smoothing of strands: resamples each polyline with `segs` points per span.

// Number of points per smoothed strand of nverts control vertices.
export function smoothedCount(nverts, segs) {
  return (nverts - 1) * segs + 1;
}

// The four uniform Catmull-Rom basis weights for each sub-step u = k / segs, k = 0..segs-1.
// Returns a Float32Array(4 * segs); computed once per `segs`, not per frame.
export function catmullWeights(segs) {
  const w = new Float32Array(4 * segs);
  for (let k = 0; k < segs; k++) {
    const u = k / segs, u2 = u * u, u3 = u2 * u;
    w[4 * k] = 0.5 * (-u3 + 2 * u2 - u);
    w[4 * k + 1] = 0.5 * (3 * u3 - 5 * u2 + 2);
    w[4 * k + 2] = 0.5 * (-3 * u3 + 4 * u2 + u);
    w[4 * k + 3] = 0.5 * (u3 - u2);
  }
  return w;
}

// Smooths nstrands strands of nverts vertices (strand-major xyz in src, starting at float
// srcOff) into dst: smoothedCount(nverts, segs) points per strand, strand-major, point k at
// float dstOff + stride * k (stride 3 for packed xyz, 4 to leave a fourth slot untouched). The
// curve passes through every control vertex; the missing neighbours at the two ends are
// mirrored (p[-1] = 2 p[0] - p[1]). weights comes from catmullWeights(segs). Allocates nothing.
export function smoothStrands(dst, dstOff, stride, src, srcOff, nstrands, nverts, segs, weights) {
  const pts = smoothedCount(nverts, segs);
  for (let s = 0; s < nstrands; s++) {
    const base = srcOff + 3 * s * nverts;
    let o = dstOff + stride * s * pts;
    for (let j = 0; j < nverts - 1; j++) {
      const i1 = base + 3 * j, i2 = i1 + 3;
      for (let c = 0; c < 3; c++) {
        const p1 = src[i1 + c], p2 = src[i2 + c];
        const p0 = j > 0 ? src[i1 - 3 + c] : 2 * p1 - p2;
        const p3 = j < nverts - 2 ? src[i2 + 3 + c] : 2 * p2 - p1;
        for (let k = 0; k < segs; k++) {
          const w = 4 * k;
          dst[o + stride * k + c] = weights[w] * p0 + weights[w + 1] * p1 + weights[w + 2] * p2 + weights[w + 3] * p3;
        }
      }
      o += stride * segs;
    }
    const last = base + 3 * (nverts - 1);
    dst[o] = src[last]; dst[o + 1] = src[last + 1]; dst[o + 2] = src[last + 2];
  }
}
