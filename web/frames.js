// Per-point frames along strands: unit tangents, and normals carried from point to point with
// minimal rotation and kept coherent over time at the root, so render strands offset from a
// guide do not twist or flip. Normals are stored as two coordinates in a basis that the shader
// rebuilds from the stored tangent (tangentBasis), which saves a texture fetch per vertex.

// The orthonormal pair (b1, b2) perpendicular to the unit vector t (Duff et al. 2017), written
// to out[0..5]. The shader computes exactly this from the same float32 tangent.
export function tangentBasis(out, tx, ty, tz) {
  const sg = tz >= 0 ? 1 : -1;
  const a = -1 / (sg + tz), b = tx * ty * a;
  out[0] = 1 + sg * tx * tx * a; out[1] = sg * b; out[2] = -sg * tx;
  out[3] = b; out[4] = sg + ty * ty * a; out[5] = -ty;
  return out;
}

// For nstrands strands of pts points whose positions are in pos (strand-major, point k at
// pos[posOff + 4 k .. +2]), writes each point's unit tangent (central differences, one-sided at
// the ends) to tan[tanOff + 4 k .. +2], and its normal N as coordinates a = N . b1 into
// pos[posOff + 4 k + 3] and b = N . b2 into tan[tanOff + 4 k + 3], (b1, b2) =
// tangentBasis(stored tangent). rootState (Float32Array of 3 * nstrands) holds each strand's
// previous root normal and is updated; a zero entry means "none yet" and is seeded from the
// axis least aligned with the root tangent. basis is a 6-float scratch array. Allocates nothing.
export function strandFrames(pos, posOff, tan, tanOff, nstrands, pts, rootState, basis) {
  let rx = 0, ry = 0, rz = 0;
  for (let s = 0; s < nstrands; s++) {
    const pb = posOff + 4 * s * pts, tb = tanOff + 4 * s * pts;
    for (let i = 0; i < pts; i++) {
      const a = pb + 4 * (i > 0 ? i - 1 : 0), c = pb + 4 * (i + 1 < pts ? i + 1 : pts - 1);
      let tx = pos[c] - pos[a], ty = pos[c + 1] - pos[a + 1], tz = pos[c + 2] - pos[a + 2];
      let l = Math.sqrt(tx * tx + ty * ty + tz * tz);
      if (l > 0) { tx /= l; ty /= l; tz /= l; } else { tx = 0; ty = -1; tz = 0; }
      const to = tb + 4 * i;
      tan[to] = tx; tan[to + 1] = ty; tan[to + 2] = tz;
      // continue from the stored float32 tangent, which is what the shader sees
      tx = tan[to]; ty = tan[to + 1]; tz = tan[to + 2];
      if (i === 0) {
        rx = rootState[3 * s]; ry = rootState[3 * s + 1]; rz = rootState[3 * s + 2];
      }
      // carry the previous normal over: project it on the plane normal to the tangent (the
      // smoothed points turn by small angles, where this matches parallel transport)
      let d = rx * tx + ry * ty + rz * tz;
      let nx = rx - d * tx, ny = ry - d * ty, nz = rz - d * tz;
      l = Math.sqrt(nx * nx + ny * ny + nz * nz);
      if (!(l > 1e-3)) {
        // no usable previous normal (first frame, or the strand folded onto it): the axis
        // least aligned with the tangent, made perpendicular
        const ax = Math.abs(tx), ay = Math.abs(ty), az = Math.abs(tz);
        if (ax <= ay && ax <= az) { nx = 1; ny = 0; nz = 0; } else if (ay <= az) { nx = 0; ny = 1; nz = 0; } else { nx = 0; ny = 0; nz = 1; }
        d = nx * tx + ny * ty + nz * tz;
        nx -= d * tx; ny -= d * ty; nz -= d * tz;
        l = Math.sqrt(nx * nx + ny * ny + nz * nz);
      }
      rx = nx / l; ry = ny / l; rz = nz / l;
      if (i === 0) { rootState[3 * s] = rx; rootState[3 * s + 1] = ry; rootState[3 * s + 2] = rz; }
      tangentBasis(basis, tx, ty, tz);
      pos[pb + 4 * i + 3] = rx * basis[0] + ry * basis[1] + rz * basis[2];
      tan[to + 3] = rx * basis[3] + ry * basis[4] + rz * basis[5];
    }
  }
}
