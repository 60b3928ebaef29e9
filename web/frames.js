// Per-point normals along strands, carried from point to point with minimal rotation and kept
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
    let l = Math.sqrt(tx * tx + ty * ty + tz * tz);
    if (l > 0) { tx /= l; ty /= l; tz /= l; } else { tx = 0; ty = -1; tz = 0; }
    // previous root normal projected on the plane normal to the tangent
    let rx = rootState[3 * s], ry = rootState[3 * s + 1], rz = rootState[3 * s + 2];
    let d = rx * tx + ry * ty + rz * tz;
    rx -= d * tx; ry -= d * ty; rz -= d * tz;
    l = Math.sqrt(rx * rx + ry * ry + rz * rz);
    if (!(l > 1e-3)) {
      // seed: the axis least aligned with the tangent, made perpendicular
      const ax = Math.abs(tx), ay = Math.abs(ty), az = Math.abs(tz);
      if (ax <= ay && ax <= az) { rx = 1; ry = 0; rz = 0; } else if (ay <= az) { rx = 0; ry = 1; rz = 0; } else { rx = 0; ry = 0; rz = 1; }
      d = rx * tx + ry * ty + rz * tz;
      rx -= d * tx; ry -= d * ty; rz -= d * tz;
      l = Math.sqrt(rx * rx + ry * ry + rz * rz);
    }
    rx /= l; ry /= l; rz /= l;
    rootState[3 * s] = rx; rootState[3 * s + 1] = ry; rootState[3 * s + 2] = rz;
    nrm[nb] = rx; nrm[nb + 1] = ry; nrm[nb + 2] = rz;
    for (let i = 1; i < pts; i++) {
      // tangent at i: central difference (one-sided at the tip)
      const a = b + 3 * (i - 1), c = i + 1 < pts ? a + 6 : a + 3;
      let ux = pos[c] - pos[a], uy = pos[c + 1] - pos[a + 1], uz = pos[c + 2] - pos[a + 2];
      l = Math.sqrt(ux * ux + uy * uy + uz * uz);
      if (l > 0) { ux /= l; uy /= l; uz /= l; } else { ux = tx; uy = ty; uz = tz; }
      // carry the previous normal over: project it on the plane normal to the new tangent (the
      // smoothed points turn by small angles, where this matches parallel transport)
      d = rx * ux + ry * uy + rz * uz;
      let nx = rx - d * ux, ny = ry - d * uy, nz = rz - d * uz;
      l = Math.sqrt(nx * nx + ny * ny + nz * nz);
      if (l > 1e-6) {
        nx /= l; ny /= l; nz /= l;
      } else {
        // the strand folded back onto the normal: take the old tangent, made perpendicular
        d = tx * ux + ty * uy + tz * uz;
        nx = tx - d * ux; ny = ty - d * uy; nz = tz - d * uz;
        l = Math.sqrt(nx * nx + ny * ny + nz * nz) || 1;
        nx /= l; ny /= l; nz /= l;
      }
      rx = nx; ry = ny; rz = nz;
      tx = ux; ty = uy; tz = uz;
      const o = nb + 3 * i;
      nrm[o] = rx; nrm[o + 1] = ry; nrm[o + 2] = rz;
    }
  }
}
