// Rigid head pose from strand roots: the rotation and translation that best map the rest roots
// (head frame) onto the streamed roots (Horn's quaternion method, 4x4 Jacobi eigen-solver).

// Eigenvector of the largest eigenvalue of the symmetric 4x4 matrix m (row-major, length 16,
// overwritten); v (length 16) receives the eigenvectors as columns. Returns the column index.
function jacobi4(m, v) {
  for (let i = 0; i < 16; i++) v[i] = i % 5 === 0 ? 1 : 0;
  for (let sweep = 0; sweep < 30; sweep++) {
    let off = 0;
    for (let p = 0; p < 3; p++) for (let q = p + 1; q < 4; q++) off += m[4 * p + q] * m[4 * p + q];
    if (off < 1e-30) break;
    for (let p = 0; p < 3; p++) {
      for (let q = p + 1; q < 4; q++) {
        const apq = m[4 * p + q];
        if (Math.abs(apq) < 1e-300) continue;
        const theta = (m[4 * q + q] - m[4 * p + p]) / (2 * apq);
        const t = Math.sign(theta || 1) / (Math.abs(theta) + Math.sqrt(theta * theta + 1));
        const c = 1 / Math.sqrt(t * t + 1), s = t * c;
        for (let k = 0; k < 4; k++) {
          const mkp = m[4 * k + p], mkq = m[4 * k + q];
          m[4 * k + p] = c * mkp - s * mkq;
          m[4 * k + q] = s * mkp + c * mkq;
        }
        for (let k = 0; k < 4; k++) {
          const mpk = m[4 * p + k], mqk = m[4 * q + k];
          m[4 * p + k] = c * mpk - s * mqk;
          m[4 * q + k] = s * mpk + c * mqk;
        }
        for (let k = 0; k < 4; k++) {
          const vkp = v[4 * k + p], vkq = v[4 * k + q];
          v[4 * k + p] = c * vkp - s * vkq;
          v[4 * k + q] = s * vkp + c * vkq;
        }
      }
    }
  }
  let best = 0;
  for (let i = 1; i < 4; i++) if (m[5 * i] > m[5 * best]) best = i;
  return best;
}

// Scratch space for fitRigid (reuse one per caller so that fitting allocates nothing).
export function rigidScratch() {
  return { m: new Float64Array(16), v: new Float64Array(16) };
}

// Fits world = t + rotate(q, rest) over n roots: rest[3 i..] are the rest roots, cur[curOff +
// curStride * i ..] the current ones; every `step`-th root is used. Writes q ([x, y, z, w],
// unit, sign chosen near the previous out.q) and t into out; returns false (out unchanged) when
// the roots do not pin a rotation down (fewer than 3, or nearly collinear).
export function fitRigid(out, rest, cur, curOff, curStride, n, step, scratch) {
  let ax = 0, ay = 0, az = 0, bx = 0, by = 0, bz = 0, cnt = 0;
  for (let i = 0; i < n; i += step) {
    const o = curOff + curStride * i;
    ax += rest[3 * i]; ay += rest[3 * i + 1]; az += rest[3 * i + 2];
    bx += cur[o]; by += cur[o + 1]; bz += cur[o + 2];
    cnt++;
  }
  if (cnt < 3) return false;
  ax /= cnt; ay /= cnt; az /= cnt; bx /= cnt; by /= cnt; bz /= cnt;
  let sxx = 0, sxy = 0, sxz = 0, syx = 0, syy = 0, syz = 0, szx = 0, szy = 0, szz = 0, spread = 0;
  for (let i = 0; i < n; i += step) {
    const o = curOff + curStride * i;
    const px = rest[3 * i] - ax, py = rest[3 * i + 1] - ay, pz = rest[3 * i + 2] - az;
    const qx = cur[o] - bx, qy = cur[o + 1] - by, qz = cur[o + 2] - bz;
    sxx += px * qx; sxy += px * qy; sxz += px * qz;
    syx += py * qx; syy += py * qy; syz += py * qz;
    szx += pz * qx; szy += pz * qy; szz += pz * qz;
    spread += px * px + py * py + pz * pz;
  }
  if (!(spread > 0)) return false;
  const m = scratch.m, v = scratch.v;
  // Horn's symmetric matrix; its top eigenvector is the quaternion (w, x, y, z)
  m[0] = sxx + syy + szz; m[1] = syz - szy; m[2] = szx - sxz; m[3] = sxy - syx;
  m[5] = sxx - syy - szz; m[6] = sxy + syx; m[7] = szx + sxz;
  m[10] = -sxx + syy - szz; m[11] = syz + szy;
  m[15] = -sxx - syy + szz;
  m[4] = m[1]; m[8] = m[2]; m[12] = m[3]; m[9] = m[6]; m[13] = m[7]; m[14] = m[11];
  const k = jacobi4(m, v);
  // collinear roots leave two top eigenvalues (nearly) equal: the rotation about that line is free
  let second = -Infinity;
  for (let i = 0; i < 4; i++) if (i !== k && m[5 * i] > second) second = m[5 * i];
  if (m[5 * k] - second < 1e-6 * spread) return false;
  let w = v[k], x = v[4 + k], y = v[8 + k], z = v[12 + k];
  const l = Math.hypot(w, x, y, z);
  w /= l; x /= l; y /= l; z /= l;
  const pq = out.q;
  if (pq[0] * x + pq[1] * y + pq[2] * z + pq[3] * w < 0) { w = -w; x = -x; y = -y; z = -z; }
  pq[0] = x; pq[1] = y; pq[2] = z; pq[3] = w;
  // t = b - R a
  const tx = 2 * (y * az - z * ay), ty = 2 * (z * ax - x * az), tz = 2 * (x * ay - y * ax);
  const rx = ax + w * tx + (y * tz - z * ty), ry = ay + w * ty + (z * tx - x * tz), rz = az + w * tz + (x * ty - y * tx);
  out.t[0] = bx - rx; out.t[1] = by - ry; out.t[2] = bz - rz;
  return true;
}
