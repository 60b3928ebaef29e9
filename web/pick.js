// Ray casts against the character's colliders (spheres, capsules, ellipsoids in the head frame).
import { quatRotate } from './mat4.js';

// Smallest t >= 0 where origin + t dir meets the sphere (center c, radius r); -1 on a miss.
export function raySphere(o, d, c, r) {
  const ox = o[0] - c[0], oy = o[1] - c[1], oz = o[2] - c[2];
  const a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  const b = ox * d[0] + oy * d[1] + oz * d[2];
  const cc = ox * ox + oy * oy + oz * oz - r * r;
  const disc = b * b - a * cc;
  if (!(a > 0) || disc < 0) return -1;
  const s = Math.sqrt(disc);
  let t = (-b - s) / a;
  if (t < 0) t = (-b + s) / a;
  return t >= 0 ? t : -1;
}

// Capsule: segment p-q swept by radius r. Tests the cylinder body then both end spheres.
export function rayCapsule(o, d, p, q, r) {
  let best = -1;
  const take = (t) => { if (t >= 0 && (best < 0 || t < best)) best = t; };
  take(raySphere(o, d, p, r));
  take(raySphere(o, d, q, r));
  const ax = q[0] - p[0], ay = q[1] - p[1], az = q[2] - p[2];
  const aa = ax * ax + ay * ay + az * az;
  if (aa > 0) {
    const wx = o[0] - p[0], wy = o[1] - p[1], wz = o[2] - p[2];
    const da = d[0] * ax + d[1] * ay + d[2] * az, wa = wx * ax + wy * ay + wz * az;
    // components perpendicular to the axis
    const dpx = d[0] - (da / aa) * ax, dpy = d[1] - (da / aa) * ay, dpz = d[2] - (da / aa) * az;
    const wpx = wx - (wa / aa) * ax, wpy = wy - (wa / aa) * ay, wpz = wz - (wa / aa) * az;
    const A = dpx * dpx + dpy * dpy + dpz * dpz, B = dpx * wpx + dpy * wpy + dpz * wpz;
    const C = wpx * wpx + wpy * wpy + wpz * wpz - r * r;
    const disc = B * B - A * C;
    if (A > 0 && disc >= 0) {
      const s = Math.sqrt(disc);
      for (const t of [(-B - s) / A, (-B + s) / A]) {
        const h = (wa + t * da) / aa;
        if (h >= 0 && h <= 1) take(t);
      }
    }
  }
  return best;
}

// Ellipsoid: center c, semi-axes radii along the axes of the unit quaternion rot [x, y, z, w].
export function rayEllipsoid(o, d, c, radii, rot) {
  // move the ray into the ellipsoid's frame (rotate by the inverse), then scale to a unit sphere
  const inv = [-rot[0], -rot[1], -rot[2], rot[3]];
  const lo = quatRotate([0, 0, 0], inv, [o[0] - c[0], o[1] - c[1], o[2] - c[2]]);
  const ld = quatRotate([0, 0, 0], inv, d);
  for (let i = 0; i < 3; i++) {
    if (!(radii[i] > 0)) return -1;
    lo[i] /= radii[i];
    ld[i] /= radii[i];
  }
  return raySphere(lo, ld, [0, 0, 0], 1);
}

// Nearest hit of a world-space ray with colliders (as in the hello message, head-local) placed
// by the head transform { position, orientation }; returns t or -1. Runs on pointer-down only.
export function pickColliders(o, d, colliders, head) {
  const q = head.orientation, pos = head.position;
  // ray into the head frame
  const inv = [-q[0], -q[1], -q[2], q[3]];
  const lo = quatRotate([0, 0, 0], inv, [o[0] - pos[0], o[1] - pos[1], o[2] - pos[2]]);
  const ld = quatRotate([0, 0, 0], inv, d);
  let best = -1;
  for (const c of colliders) {
    let t = -1;
    if (c.kind === 'sphere') t = raySphere(lo, ld, c.center, c.radius);
    else if (c.kind === 'capsule') t = rayCapsule(lo, ld, c.a, c.b, c.radius);
    else if (c.kind === 'ellipsoid') t = rayEllipsoid(lo, ld, c.center, c.radii, c.rotation || [0, 0, 0, 1]);
    if (t >= 0 && (best < 0 || t < best)) best = t;
  }
  return best;
}
