// shaders: pushing a point out of one collider or out of the distance grid (collide_one and
// collide_sdf of sim_cpu_chain.c), shared by the chain pass and the PBD substep.

// Pushes p out of collider ci (its world pose this substep) onto its surface. The fields are
// read where they are used: a collider is 160 bytes and most pushes need 32 of them.
vec3 collide_one(vec3 p, uint ci)
{
    vec4 a = F.col[ci].a;
    uint kind = uint(a.w);
    vec3 c = a.xyz;
    if (kind == 2u) {
        vec3 d = p - c;
        vec3 m0 = F.col[ci].m[0].xyz, m1 = F.col[ci].m[1].xyz, m2 = F.col[ci].m[2].xyz;
        float sx = m0.x * d.x + m0.y * d.y + m0.z * d.z;
        float sy = m1.x * d.x + m1.y * d.y + m1.z * d.z;
        float sz = m2.x * d.x + m2.y * d.y + m2.z * d.z;
        float sl = sqrt(sx * sx + sy * sy + sz * sz);
        if (!(sl < 1.0)) return p;
        bool degenerate = sl < 1e-12;
        float k = 1.0 / max(sl, 1e-12);
        float ux = degenerate ? 0.0 : sx * k, uy = degenerate ? 1.0 : sy * k, uz = degenerate ? 0.0 : sz * k;
        vec3 n0 = F.col[ci].nrm[0].xyz, n1 = F.col[ci].nrm[1].xyz, n2 = F.col[ci].nrm[2].xyz;
        float px = n0.x * ux + n0.y * uy + n0.z * uz;
        float py = n1.x * ux + n1.y * uy + n1.z * uz;
        float pz = n2.x * ux + n2.y * uy + n2.z * uz;
        return vec3(c.x + px, c.y + py, c.z + pz);
    }
    vec4 b = F.col[ci].b;
    vec3 e = kind == 1u ? b.xyz - a.xyz : vec3(0.0);
    float ee = e.x * e.x + e.y * e.y + e.z * e.z;
    float inv_ee = kind == 1u && ee > 0.0 ? 1.0 / ee : 0.0;
    vec3 d0 = p - a.xyz;
    float t = (d0.x * e.x + d0.y * e.y + d0.z * e.z) * inv_ee;
    t = min(max(t, 0.0), 1.0);
    c = a.xyz + e * t;
    vec3 d = p - c;
    float dl = v3len(d);
    float r = b.w;
    if (!(dl < r)) return p;
    float k = r / max(dl, 1e-12);
    return vec3(c.x + d.x * k, dl < 1e-12 ? c.y + r : c.y + d.y * k, c.z + d.z * k);
}

// One axis of core_sdf_sample (server/core/sdf.c).
uint sdf_axis(float p, float lo, uint n, float cell, out float f, out float o, out float q)
{
    float hi = lo + float(n - 1u) * cell;
    float c = min(max(p, lo), hi);
    float u = (c - lo) / cell;
    float fl = min(floor(u), float(n - 2u));
    f = u - fl;
    o = p - c;
    q = c;
    return uint(fl);
}

// core_sdf_sample (server/core/sdf.c) operation for operation: trilinear distance at p (head
// frame) and the gradient of the interpolant. p must be finite.
float sdf_sample(vec3 p, out vec3 grad)
{
    uvec3 dims = F.sdf_dims.xyz;
    vec3 org = F.sdf_origin.xyz;
    float cell = F.sdf_origin.w;
    float fx, fy, fz, ox, oy, oz, qx, qy, qz;
    uint i = sdf_axis(p.x, org.x, dims.x, cell, fx, ox, qx);
    uint j = sdf_axis(p.y, org.y, dims.y, cell, fy, oy, qy);
    uint k = sdf_axis(p.z, org.z, dims.z, cell, fz, oz, qz);
    uint sx = 1u, sy = dims.x, sz = dims.x * dims.y;
    uint c = i + j * sy + k * sz;
    float d000 = SDF.d[c], d100 = SDF.d[c + sx], d010 = SDF.d[c + sy], d110 = SDF.d[c + sx + sy];
    float d001 = SDF.d[c + sz], d101 = SDF.d[c + sx + sz], d011 = SDF.d[c + sy + sz], d111 = SDF.d[c + sx + sy + sz];
    float e00 = d000 + (d100 - d000) * fx, e10 = d010 + (d110 - d010) * fx;
    float e01 = d001 + (d101 - d001) * fx, e11 = d011 + (d111 - d011) * fx;
    float g0 = e00 + (e10 - e00) * fy, g1 = e01 + (e11 - e01) * fy;
    float inside = g0 + (g1 - g0) * fz;
    float outside = sqrt(ox * ox + oy * oy + oz * oz);
    float gx0 = (d100 - d000) + ((d110 - d010) - (d100 - d000)) * fy;
    float gx1 = (d101 - d001) + ((d111 - d011) - (d101 - d001)) * fy;
    float gx = (gx0 + (gx1 - gx0) * fz) / cell;
    float gy = ((e10 - e00) + ((e11 - e01) - (e10 - e00)) * fz) / cell;
    float gz = (g1 - g0) / cell;
    float inv = 1.0 / max(outside, 1e-30);
    grad = vec3(qx == p.x ? gx : ox * inv, qy == p.y ? gy : oy * inv, qz == p.z ? gz : oz * inv);
    return inside + outside;
}

// collide_sdf of sim_cpu_chain.c for one point at substep k: out of the distance grid to distance
// target from its surface (the skin; the PBD solver: the vertex's contact floor).
vec3 sdf_push(vec3 p, uint k, float target)
{
    vec3 pos = F.sub[k].pos.xyz;
    vec3 m0 = F.sub[k].to_head[0].xyz, m1 = F.sub[k].to_head[1].xyz, m2 = F.sub[k].to_head[2].xyz;
    float cell = F.sdf_origin.w;
    vec3 org = F.sdf_origin.xyz;
    float hx = org.x + float(F.sdf_dims.x - 1u) * cell, hy = org.y + float(F.sdf_dims.y - 1u) * cell;
    float hz = org.z + float(F.sdf_dims.z - 1u) * cell;
    float dx = p.x - pos.x, dy = p.y - pos.y, dz = p.z - pos.z;
    float qx = m0.x * dx + m0.y * dy + m0.z * dz;
    float qy = m1.x * dx + m1.y * dy + m1.z * dz;
    float qz = m2.x * dx + m2.y * dy + m2.z * dz;
    if (!(qx >= org.x && qx <= hx && qy >= org.y && qy <= hy && qz >= org.z && qz <= hz)) return p;
    vec3 g;
    float d = sdf_sample(vec3(qx, qy, qz), g);
    float push = target - d;
    float gl = sqrt(g.x * g.x + g.y * g.y + g.z * g.z);
    if (!(push > 0.0) || !(gl > 1e-12)) return p;
    float kk = push / gl;
    vec3 n0 = F.sub[k].from_head[0].xyz, n1 = F.sub[k].from_head[1].xyz, n2 = F.sub[k].from_head[2].xyz;
    return vec3(p.x + (n0.x * g.x + n0.y * g.y + n0.z * g.z) * kk, p.y + (n1.x * g.x + n1.y * g.y + n1.z * g.z) * kk,
                p.z + (n2.x * g.x + n2.y * g.y + n2.z * g.z) * kk);
}
