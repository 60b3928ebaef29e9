// shaders: the chain along a strand (port of sim_cpu_chain.c), shared by both chain strategies.
// A workgroup is a chunk of CHUNK consecutive strands, as the C backend's, so that collider
// culling (per chunk and level) picks the same colliders in the same order.

const uint CHUNK = uint(SIM_CHUNK);

// The chunk's bounding box per level as order-preserving uint keys (atomic min/max): three
// buffers in turn, so that one barrier per level separates writing, reading and resetting.
// [6 * b + 0..2] min, [6 * b + 3..5] max; box_nan[b]: a NaN was seen.
shared uint box_key[18];
shared uint box_nan[3];

void box_reset(uint b)
{
    for (uint k = 0u; k < 3u; k++) {
        box_key[6u * b + k] = 0xffffffffu;
        box_key[6u * b + 3u + k] = 0u;
    }
    box_nan[b] = 0u;
}

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
// invocation of the workgroup calls it with the same box buffer b (it synchronises); buffer b
// must have been reset before the previous barrier; thread 0 resets buffer `next`. hit[]
// receives indices into F.col.
uint chunk_colliders(bool live, vec3 c, vec3 p, uint k, uint b, uint next, out uint hit[MAX_COLLIDERS])
{
    bool nan = live && (any(greaterThan(floatBitsToUint(c) & 0x7fffffffu, uvec3(0x7f800000u))) ||
                        any(greaterThan(floatBitsToUint(p) & 0x7fffffffu, uvec3(0x7f800000u))));
    if (nan) atomicOr(box_nan[b], 1u);
    if (live && !nan) {
        vec3 lo = min(c, p), hi = max(c, p);
        for (uint j = 0u; j < 3u; j++) {
            atomicMin(box_key[6u * b + j], fkey(lo[j]));
            atomicMax(box_key[6u * b + 3u + j], fkey(hi[j]));
        }
    }
    barrier();
    vec3 lo = vec3(keyf(box_key[6u * b]), keyf(box_key[6u * b + 1u]), keyf(box_key[6u * b + 2u])) - F.grow;
    vec3 hi = vec3(keyf(box_key[6u * b + 3u]), keyf(box_key[6u * b + 4u]), keyf(box_key[6u * b + 5u])) + F.grow;
    bool finite = box_nan[b] == 0u;
    if (gl_LocalInvocationID.x == 0u && next != b) box_reset(next);
    uint nhit = 0u, taken = 0u;
    for (bool grew = true; grew;) {
        grew = false;
        for (uint j = 0u; j < F.ncolliders; j++) {
            vec3 wlo = F.col[k * MAX_COLLIDERS + j].lo.xyz, whi = F.col[k * MAX_COLLIDERS + j].hi.xyz;
            bool overlap = all(lessThanEqual(lo, whi)) && all(greaterThanEqual(hi, wlo));
            if ((taken & (1u << j)) != 0u || !(overlap || !finite)) continue;
            taken |= 1u << j;
            hit[nhit++] = k * MAX_COLLIDERS + j;
            lo = min(lo, wlo);
            hi = max(hi, whi);
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
    vec3 pv;   // final velocity of the last finalised level (the root's, then level l - 2's)
    bool bad;  // a non-finite value was seen
};

// Kinematic root of strand s at substep k: writes its x and v, returns the chain start.
Chain chain_root(bool live, uint s, uint k)
{
    Xf hd = F.head[k];
    Chain ch;
    ch.pr = live ? ldRest(s) : vec3(0.0);
    ch.p = xf_point(hd, ch.pr);
    ch.pv = vec3(0.0);
    if (live) {
        ch.pv = (ch.p - ldX(s)) * F.inv_dt_k;
        stV(s, ch.pv);
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
    return ldX(i) + ldV(i) * F.drag_keep * dt + acc * dt2;
}

// Level l >= 1 of strand s from its prediction: global shape (11), local shape (12),
// follow the leader (13), collisions; finalises level l - 1 >= 1 with the DFTL velocity
// correction (14) and internal damping, and moves the chain state on to level l. Every invocation of the workgroup
// calls it with the same box buffers b, next (see chunk_colliders); inactive ones (past the
// last strand) write nothing.
void chain_solve(bool live, uint s, uint l, uint k, uint b, uint next, vec3 pred, inout Chain ch)
{
    Xf hd = F.head[k];
    uint i = l * NS + s;
    vec2 sgl = F.stiff[l];
    vec3 rl = live ? ldRest(i) : vec3(0.0);
    vec3 xo = live ? ldX(i) : vec3(0.0);
    vec3 xs = pred;
    xs += sgl.x * ((qrot(hd.rot, rl) + hd.pos.xyz) - xs);
    // the DFTL correction carries the local-shape and inextensibility corrections (not the
    // global pull, whose reaction is the head's) to the parent
    vec3 xg = xs;
    vec3 r = rl - ch.pr;
    vec3 tgt = ch.p + qrot(ch.q, r);
    xs += sgl.y * (tgt - xs);
    float L = v3len(r);
    vec3 dd = ch.p - xs;
    float len = v3len(dd);
    xs = len > 1e-12 ? ch.p - dd * (L / max(len, 1e-12)) : tgt;
    vec3 delta = xs - xg;
    if (F.ncolliders > 0u) {
        uint hit[MAX_COLLIDERS];
        uint nhit = chunk_colliders(live, xs, ch.p, k, b, next, hit);
        if (nhit > 0u) {
            for (uint it = 0u; it < COLLISION_ITERATIONS; it++) {
                for (uint h = 0u; h < nhit; h++) xs = collide_one(xs, hit[h]);
                xs = follow(ch.p, xs, r);
            }
            uint passes = nhit > 1u ? CREVICE_PASSES : 1u;
            for (uint pass = 0u; pass < passes; pass++)
                for (uint h = 0u; h < nhit; h++) xs = collide_one(xs, hit[h]);
        }
    }
    if (live && l > 1u) {
        uint j = i - NS;
        vec3 v = (ch.p - ch.o) * F.inv_dt_k - F.dftl * delta * F.inv_dt_k;
        ch.pv = ch.pv + F.accel.w * (v - ch.pv); // internal damping toward the parent's velocity
        stV(j, ch.pv);
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
    vec3 v = (ch.p - ch.o) * F.inv_dt_k;
    stV(i, ch.pv + F.accel.w * (v - ch.pv));
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
