// Pixel statistics for the browser e2e test: share of hair-coloured pixels, shading spread,
// and how much of the picture changed between two frames (RGBA8 buffers).

// Warm, saturated pixels (red above green above blue, red clearly above blue) are hair: the
// viewer's default hair is brown, its head grey-blue and its background near black.
export function isHair(r, g, b) {
  return r >= g && g >= b && r - b >= 25 && r >= 40;
}

const luma = (r, g, b) => 0.2126 * r + 0.7152 * g + 0.0722 * b;

// { hairShare, hairLumaSpread (95th - 5th percentile of hair luminance), lumaStd (all pixels) }
export function pixelStats(rgba) {
  const n = rgba.length >> 2;
  const hist = new Uint32Array(256);
  let hair = 0, sum = 0, sum2 = 0;
  for (let i = 0; i < n; i++) {
    const r = rgba[4 * i], g = rgba[4 * i + 1], b = rgba[4 * i + 2];
    const y = luma(r, g, b);
    sum += y;
    sum2 += y * y;
    if (isHair(r, g, b)) { hair++; hist[Math.min(255, Math.round(y))]++; }
  }
  const pct = (p) => {
    let acc = 0;
    for (let v = 0; v < 256; v++) { acc += hist[v]; if (acc >= p * hair) return v; }
    return 255;
  };
  const mean = n ? sum / n : 0;
  return {
    hairShare: n ? hair / n : 0,
    hairLumaSpread: hair ? pct(0.95) - pct(0.05) : 0,
    lumaStd: n ? Math.sqrt(Math.max(0, sum2 / n - mean * mean)) : 0,
  };
}

// Share of pixels whose largest channel difference between a and b exceeds threshold.
export function diffShare(a, b, threshold) {
  if (a.length !== b.length) return 1;
  const n = a.length >> 2;
  let changed = 0;
  for (let i = 0; i < n; i++) {
    const d = Math.max(Math.abs(a[4 * i] - b[4 * i]), Math.abs(a[4 * i + 1] - b[4 * i + 1]), Math.abs(a[4 * i + 2] - b[4 * i + 2]));
    if (d > threshold) changed++;
  }
  return n ? changed / n : 0;
}
