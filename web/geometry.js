// Collider meshes: a unit sphere and a unit open cylinder (y from 0 to 1), with normals.

// Unit sphere of rings x segments quads. Returns { positions, normals, indices } (normals =
// positions).
export function unitSphere(rings = 24, segments = 48) {
  const positions = [], indices = [];
  for (let r = 0; r <= rings; r++) {
    const th = (Math.PI * r) / rings, y = Math.cos(th), s = Math.sin(th);
    for (let k = 0; k <= segments; k++) {
      const ph = (2 * Math.PI * k) / segments;
      positions.push(s * Math.cos(ph), y, s * Math.sin(ph));
    }
  }
  const row = segments + 1;
  for (let r = 0; r < rings; r++) {
    for (let k = 0; k < segments; k++) {
      const a = r * row + k, b = a + row;
      indices.push(a, a + 1, b, a + 1, b + 1, b);
    }
  }
  const p = Float32Array.from(positions);
  return { positions: p, normals: p, indices: Uint16Array.from(indices) };
}

// Open cylinder of radius 1 around the y axis from y = 0 to y = 1.
export function unitCylinder(segments = 48) {
  const positions = [], normals = [], indices = [];
  for (let k = 0; k <= segments; k++) {
    const ph = (2 * Math.PI * k) / segments, x = Math.cos(ph), z = Math.sin(ph);
    positions.push(x, 0, z, x, 1, z);
    normals.push(x, 0, z, x, 0, z);
  }
  for (let k = 0; k < segments; k++) {
    const a = 2 * k;
    indices.push(a, a + 2, a + 1, a + 1, a + 2, a + 3);
  }
  return { positions: Float32Array.from(positions), normals: Float32Array.from(normals), indices: Uint16Array.from(indices) };
}

// Local placements (head frame) of the meshes that draw one collider from the hello message:
// a list of { mesh: 'sphere' | 'cylinder', t: [x, y, z], q: [x, y, z, w], s: [sx, sy, sz] }.
// Unknown kinds or non-finite numbers give an empty list.
export function colliderParts(c) {
  const finite = (a, n) => Array.isArray(a) && a.length === n && a.every(Number.isFinite);
  if (!c || typeof c !== 'object') return [];
  if (c.kind === 'sphere' && finite(c.center, 3) && c.radius > 0) {
    return [{ mesh: 'sphere', t: c.center, q: [0, 0, 0, 1], s: [c.radius, c.radius, c.radius] }];
  }
  if (c.kind === 'ellipsoid' && finite(c.center, 3) && finite(c.radii, 3) && c.radii.every((r) => r > 0)) {
    const q = finite(c.rotation, 4) ? c.rotation : [0, 0, 0, 1];
    return [{ mesh: 'sphere', t: c.center, q, s: c.radii }];
  }
  if (c.kind === 'capsule' && finite(c.a, 3) && finite(c.b, 3) && c.radius > 0) {
    const r = c.radius, d = [c.b[0] - c.a[0], c.b[1] - c.a[1], c.b[2] - c.a[2]];
    const len = Math.hypot(d[0], d[1], d[2]);
    const parts = [
      { mesh: 'sphere', t: c.a, q: [0, 0, 0, 1], s: [r, r, r] },
      { mesh: 'sphere', t: c.b, q: [0, 0, 0, 1], s: [r, r, r] },
    ];
    if (len > 0) {
      // rotation taking +y onto d: axis y x d, angle acos(y . d)
      const ux = d[0] / len, uy = d[1] / len, uz = d[2] / len;
      let q = [uz, 0, -ux, 1 + uy];
      if (1 + uy < 1e-9) q = [1, 0, 0, 0];
      const l = Math.hypot(q[0], q[1], q[2], q[3]);
      parts.push({ mesh: 'cylinder', t: c.a, q: q.map((x) => x / l), s: [r, len, r] });
    }
    return parts;
  }
  return [];
}
