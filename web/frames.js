// Per-point normals along strands by rotation-minimising (double reflection) transport, kept
// coherent over time at the root, so render strands offset from a guide do not twist or flip.

// Computes a unit normal for every point of nstrands strands of pts points (strand-major xyz in
// pos from float posOff) into nrm (same layout, from float nrmOff). rootState (Float32Array of
// 3 * nstrands) holds each strand's previous root normal and is updated; a zero entry means
// "none yet" and is seeded from a fixed reference axis. Tangents are central differences.
// Allocates nothing.
export function strandNormals(nrm, nrmOff, pos, posOff, nstrands, pts, rootState) {
  for (let s = 0; s < nstrands; s++) {
    const b = posOff + 3 * s * pts, nb = nrmOff + 3 * s * pts;
    // root tangent
    let tx = pos[b + 3] - pos[b], ty = pos[b + 4] - pos[b + 1], tz = pos[b + 5] - pos[b + 2];
    let l = Math.hypot(tx, ty, tz);
    if (l > 0) { tx /= l; ty /= l; tz /= l; } else { tx = 0; ty = -1; tz = 0; }
    // previous root normal projected on the plane normal to the tangent
    let rx = rootState[3 * s], ry = rootState[3 * s + 1], rz = rootState[3 * s + 2];
    let d = rx * tx + ry * ty + rz * tz;
    rx -= d * tx; ry -= d * ty; rz -= d * tz;
    l = Math.hypot(rx, ry, rz);
    if (!(l > 1e-3)) {
      // seed: the axis least aligned with the tangent, made perpendicular
      const ax = Math.abs(tx), ay = Math.abs(ty), az = Math.abs(tz);
      if (ax <= ay && ax <= az) { rx = 1; ry = 0; rz = 0; } else if (ay <= az) { rx = 0; ry = 1; rz = 0; } else { rx = 0; ry = 0; rz = 1; }
      d = rx * tx + ry * ty + rz * tz;
      rx -= d * tx; ry -= d * ty; rz -= d * tz;
      l = Math.hypot(rx, ry, rz);
    }
    rx /= l; ry /= l; rz /= l;
    rootState[3 * s] = rx; rootState[3 * s + 1] = ry; rootState[3 * s + 2] = rz;
    nrm[nb] = rx; nrm[nb + 1] = ry; nrm[nb + 2] = rz;
    for (let i = 0; i < pts - 1; i++) {
      const p = b + 3 * i;
      // next tangent: central difference at i+1 (one-sided at the tip)
      const q = i + 2 < pts ? p + 6 : p + 3;
      let ux = pos[q] - pos[p], uy = pos[q + 1] - pos[p + 1], uz = pos[q + 2] - pos[p + 2];
      l = Math.hypot(ux, uy, uz);
      if (l > 0) { ux /= l; uy /= l; uz /= l; } else { ux = tx; uy = ty; uz = tz; }
      // reflection 1 across the plane bisecting x_i, x_{i+1}
      const v1x = pos[p + 3] - pos[p], v1y = pos[p + 4] - pos[p + 1], v1z = pos[p + 5] - pos[p + 2];
      const c1 = v1x * v1x + v1y * v1y + v1z * v1z;
      let rLx = rx, rLy = ry, rLz = rz, tLx = tx, tLy = ty, tLz = tz;
      if (c1 > 0) {
        const fr = 2 * (v1x * rx + v1y * ry + v1z * rz) / c1, ft = 2 * (v1x * tx + v1y * ty + v1z * tz) / c1;
        rLx -= fr * v1x; rLy -= fr * v1y; rLz -= fr * v1z;
        tLx -= ft * v1x; tLy -= ft * v1y; tLz -= ft * v1z;
      }
      // reflection 2 maps the reflected tangent onto the next tangent
      const v2x = ux - tLx, v2y = uy - tLy, v2z = uz - tLz;
      const c2 = v2x * v2x + v2y * v2y + v2z * v2z;
      if (c2 > 1e-12) {
        const f = 2 * (v2x * rLx + v2y * rLy + v2z * rLz) / c2;
        rLx -= f * v2x; rLy -= f * v2y; rLz -= f * v2z;
      }
      // re-orthonormalise against rounding
      d = rLx * ux + rLy * uy + rLz * uz;
      rx = rLx - d * ux; ry = rLy - d * uy; rz = rLz - d * uz;
      l = Math.hypot(rx, ry, rz) || 1;
      rx /= l; ry /= l; rz /= l;
      tx = ux; ty = uy; tz = uz;
      const o = nb + 3 * (i + 1);
      nrm[o] = rx; nrm[o + 1] = ry; nrm[o + 2] = rz;
    }
  }
}
