// shaders: the chain along a strand (port of sim_cpu_chain.c), shared by both chain strategies.
// A workgroup is a chunk of CHUNK consecutive strands, as the C backend's, so that collider
// culling (per chunk and level) picks the same colliders in the same order.

const uint CHUNK = 64u;

// Per-level reduction of the chunk's bounding box: xyz min in [0, CHUNK), max in [CHUNK, 2 CHUNK).
shared vec3 chunk_box[2u * CHUNK];
shared uint chunk_nan;

// Pushes p out of one collider onto its surface.
vec3 collide_one(vec3 p, Collider w)
{
    uint kind = uint(w.a.w);
    vec3 c = w.a.xyz;
    if (kind == 2u) {
        vec3 d = p - c;
        float sx = w.m[0].x * d.x + w.m[0].y * d.y + w.m[0].z * d.z;
        float sy = w.m[1].x * d.x + w.m[1].y * d.y + w.m[1].z * d.z;
        float sz = w.m[2].x * d.x + w.m[2].y * d.y + w.m[2].z * d.z;
        float sl = sqrt(sx * sx + sy * sy + sz * sz);
        if (!(sl < 1.0)) return p;
        bool degenerate = sl < 1e-12;
        float k = 1.0 / max(sl, 1e-12);
        float ux = degenerate ? 0.0 : sx * k, uy = degenerate ? 1.0 : sy * k, uz = degenerate ? 0.0 : sz * k;
        float px = w.nrm[0].x * ux + w.nrm[0].y * uy + w.nrm[0].z * uz;
        float py = w.nrm[1].x * ux + w.nrm[1].y * uy + w.nrm[1].z * uz;
        float pz = w.nrm[2].x * ux + w.nrm[2].y * uy + w.nrm[2].z * uz;
        return vec3(c.x + px, c.y + py, c.z + pz);
    }
    vec3 e = kind == 1u ? w.b.xyz - w.a.xyz : vec3(0.0);
    float ee = e.x * e.x + e.y * e.y + e.z * e.z;
    float inv_ee = kind == 1u && ee > 0.0 ? 1.0 / ee : 0.0;
    vec3 d0 = p - w.a.xyz;
    float t = (d0.x * e.x + d0.y * e.y + d0.z * e.z) * inv_ee;
    t = min(max(t, 0.0), 1.0);
    c = w.a.xyz + e * t;
    vec3 d = p - c;
    float dl = v3len(d);
    float r = w.b.w;
    if (!(dl < r)) return p;
    float k = r / max(dl, 1e-12);
    return vec3(c.x + d.x * k, dl < 1e-12 ? c.y + r : c.y + d.y * k, c.z + d.z * k);
}

// Follow the leader: puts c at distance |r| from p (unchanged when c sits on p).
vec3 follow(vec3 p, vec3 c, vec3 r)
{
    float L = v3len(r);
    vec3 dd = p - c;
    float len = v3len(dd);
    return len > 1e-12 ? p - dd * (L / max(len, 1e-12)) : c;
}

// The colliders the chunk can reach at this level, in the C backend's order: those whose box
// overlaps the chunk's box of positions and parents (grown by the longest segment), then
// those overlapping the box grown by the colliders taken, until nothing changes. Every
// invocation of the workgroup must call it (it synchronises); inactive ones pass live = false.
uint chunk_colliders(bool live, vec3 c, vec3 p, uint k, out uint hit[MAX_COLLIDERS])
{
    uint t = gl_LocalInvocationID.x;
    bool nan = live && (any(greaterThan(floatBitsToUint(c) & 0x7fffffffu, uvec3(0x7f800000u))) ||
                          any(greaterThan(floatBitsToUint(p) & 0x7fffffffu, uvec3(0x7f800000u))));
    if (t == 0u) chunk_nan = 0u;
    chunk_box[t] = live && !nan ? min(c, p) : vec3(uintBitsToFloat(0x7f800000u));
    chunk_box[CHUNK + t] = live && !nan ? max(c, p) : vec3(-uintBitsToFloat(0x7f800000u));
    barrier();
    if (nan) atomicOr(chunk_nan, 1u);
    for (uint w = CHUNK / 2u; w > 0u; w /= 2u) {
        if (t < w) {
            chunk_box[t] = min(chunk_box[t], chunk_box[t + w]);
            chunk_box[CHUNK + t] = max(chunk_box[CHUNK + t], chunk_box[CHUNK + t + w]);
        }
        barrier();
    }
    vec3 lo = chunk_box[0] - F.grow, hi = chunk_box[CHUNK] + F.grow;
    bool finite = chunk_nan == 0u;
    barrier(); // everyone has read the box before the next level overwrites it
    uint nhit = 0u, taken = 0u;
    for (bool grew = true; grew;) {
        grew = false;
        for (uint j = 0u; j < F.ncolliders; j++) {
            Collider w = F.col[k * MAX_COLLIDERS + j];
            bool overlap = all(lessThanEqual(lo, w.hi.xyz)) && all(greaterThanEqual(hi, w.lo.xyz));
            if ((taken & (1u << j)) != 0u || !(overlap || !finite)) continue;
            taken |= 1u << j;
            hit[nhit++] = j;
            lo = min(lo, w.lo.xyz);
            hi = max(hi, w.hi.xyz);
            grew = true;
        }
    }
    return nhit;
}

// The chain state of one strand between levels.
struct Chain {
    vec3 p;    // previous level's final position
    vec3 o;    // previous level's position at the substep start
    vec3 pr;   // previous level's rest position
    vec4 q;    // previous level's frame
    bool bad;  // a non-finite value was seen
};

// Kinematic root of strand s at substep k: writes its x and v, returns the chain start.
Chain chain_root(bool live, uint s, uint k)
{
    Xf hd = F.head[k];
    Chain ch;
    ch.pr = live ? ldRest(s) : vec3(0.0);
    ch.p = xf_point(hd, ch.pr);
    if (live) {
        stV(s, (ch.p - ldX(s)) * F.inv_dt_k);
        stX(s, ch.p);
    }
    ch.o = ch.p;
    ch.q = hd.rot;
    ch.bad = !finite3(ch.p);
    return ch;
}

// Predicted position of particle i (eq. 1), in the C backend's operation order.
vec3 chain_predict(uint i)
{
    float dt = F.dt_k, dt2 = dt * dt;
    vec3 acc = F.accel.xyz;
    if ((F.flags & FLAG_SPH) != 0u) acc += ldA(i);
    return ldX(i) + ldV(i) * dt + acc * dt2;
}

// Level l >= 1 of strand s from its prediction: global shape (11), local shape (12),
// follow the leader (13), collisions; finalises level l - 1 >= 1 with the DFTL velocity
// correction (14) and moves the chain state on to level l. Every invocation of the workgroup
// calls it (collider culling synchronises); inactive ones (past the last strand) write nothing.
void chain_solve(bool live, uint s, uint l, uint k, vec3 pred, inout Chain ch)
{
    Xf hd = F.head[k];
    uint i = l * NS + s;
    vec2 sgl = F.stiff[l];
    vec3 rl = live ? ldRest(i) : vec3(0.0);
    vec3 xo = live ? ldX(i) : vec3(0.0);
    vec3 xs = pred;
    xs += sgl.x * ((qrot(hd.rot, rl) + hd.pos.xyz) - xs);
    vec3 r = rl - ch.pr;
    vec3 tgt = ch.p + qrot(ch.q, r);
    xs += sgl.y * (tgt - xs);
    float L = v3len(r);
    vec3 dd = ch.p - xs;
    float len = v3len(dd);
    xs = len > 1e-12 ? ch.p - dd * (L / max(len, 1e-12)) : tgt;
    vec3 delta = xs - pred;
    if (F.ncolliders > 0u) {
        uint hit[MAX_COLLIDERS];
        uint nhit = chunk_colliders(live, xs, ch.p, k, hit);
        if (nhit > 0u) {
            for (uint it = 0u; it < COLLISION_ITERATIONS; it++) {
                for (uint h = 0u; h < nhit; h++) xs = collide_one(xs, F.col[k * MAX_COLLIDERS + hit[h]]);
                xs = follow(ch.p, xs, r);
            }
            uint passes = nhit > 1u ? CREVICE_PASSES : 1u;
            for (uint pass = 0u; pass < passes; pass++)
                for (uint h = 0u; h < nhit; h++) xs = collide_one(xs, F.col[k * MAX_COLLIDERS + hit[h]]);
        }
    }
    if (live && l > 1u) {
        uint j = i - NS;
        stV(j, (ch.p - ch.o) * F.inv_dt_k - F.damping * delta * F.inv_dt_k);
        stX(j, ch.p);
    }
    // carry the frame: rotate the rest direction onto the solved one
    vec3 e = r * (1.0 / sqrt(max(r.x * r.x + r.y * r.y + r.z * r.z, 1e-30)));
    vec3 d = qrot(qconj(ch.q), xs - ch.p);
    d = d * (1.0 / sqrt(max(d.x * d.x + d.y * d.y + d.z * d.z, 1e-30)));
    vec4 rq = vec4(e.y * d.z - e.z * d.y, e.z * d.x - e.x * d.z, e.x * d.y - e.y * d.x,
                   1.0 + e.x * d.x + e.y * d.y + e.z * d.z);
    rq = rq * (1.0 / sqrt(max(rq.x * rq.x + rq.y * rq.y + rq.z * rq.z + rq.w * rq.w, 1e-30)));
    vec4 nq = qmul(ch.q, rq);
    ch.q = nq * (1.0 / sqrt(max(nq.x * nq.x + nq.y * nq.y + nq.z * nq.z + nq.w * nq.w, 1e-30)));
    ch.bad = ch.bad || !finite3(xs) || !finite3(delta) || !finite3(xo);
    ch.p = xs;
    ch.o = xo;
    ch.pr = rl;
}

// Finalises the last level of strand s; a strand that saw a non-finite value goes back to
// its rest pose under the substep's head transform and is counted.
void chain_finish(uint s, uint k, Chain ch)
{
    uint i = (NV - 1u) * NS + s;
    stV(i, (ch.p - ch.o) * F.inv_dt_k);
    stX(i, ch.p);
    if (!ch.bad) return;
    Xf hd = F.head[k];
    for (uint l = 0u; l < NV; l++) {
        uint j = l * NS + s;
        stX(j, xf_point(hd, ldRest(j)));
        stV(j, vec3(0.0));
    }
    atomicAdd(STATS.nan_resets, 1u);
}
