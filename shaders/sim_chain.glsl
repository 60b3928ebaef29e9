// shaders: the chain along a strand (port of sim_cpu_chain.c), run a level at a time by sim_chain_level.comp.
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

// Contacts are on (the chunk's box buffers are used): uniform across the workgroup.
bool contacts_on() { return F.ncolliders > 0u || F.sdf_dims.w != 0u; }

// Pushes out of collider ci, or the distance grid of substep k when ci == ~0u.
vec3 push_any(vec3 p, uint ci, uint k) { return ci == ~0u ? sdf_push(p, k, SDF_SKIN) : collide_one(p, ci); }

// collide_mid: the segment p -> c's midpoint pushed out, the vertex moved twice as far.
vec3 collide_mid(vec3 p, vec3 c, uint ci, uint k)
{
    vec3 m0 = (p + c) * 0.5;
    vec3 m1 = push_any(m0, ci, k);
    return c + (m1 - m0) * 2.0;
}

// contact_friction of sim_cpu_chain.c: xo is the vertex's position at the substep start.
vec3 contact_friction(vec3 c, vec3 n, vec3 xo, uint k)
{
    float al = sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    if (!(al > 0.0)) return c;
    float inv = 1.0 / al, ux = n.x * inv, uy = n.y * inv, uz = n.z * inv;
    vec4 c0 = F.sub[k].carry[0], c1 = F.sub[k].carry[1], c2 = F.sub[k].carry[2];
    float ox = c0.x * xo.x + c0.y * xo.y + c0.z * xo.z + c0.w;
    float oy = c1.x * xo.x + c1.y * xo.y + c1.z * xo.z + c1.w;
    float oz = c2.x * xo.x + c2.y * xo.y + c2.z * xo.z + c2.w;
    float dx = c.x - ox, dy = c.y - oy, dz = c.z - oz;
    float dn = dx * ux + dy * uy + dz * uz;
    float tx = dx - dn * ux, ty = dy - dn * uy, tz = dz - dn * uz;
    float tl = sqrt(tx * tx + ty * ty + tz * tz), lim = F.friction * al;
    float f = tl <= lim ? 1.0 : lim / tl;
    return vec3(c.x - tx * f, c.y - ty * f, c.z - tz * f);
}

// contact_slide of sim_cpu_chain.c: rest length |r| to p along the tangent plane of n.
vec3 contact_slide(vec3 p, vec3 c, vec3 r, vec3 n)
{
    float al = sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    if (!(al > 0.0)) return c;
    float inv = 1.0 / al, ux = n.x * inv, uy = n.y * inv, uz = n.z * inv;
    float L2 = r.x * r.x + r.y * r.y + r.z * r.z, L = sqrt(L2);
    float dx = c.x - p.x, dy = c.y - p.y, dz = c.z - p.z;
    float dn = dx * ux + dy * uy + dz * uz;
    float tx = dx - dn * ux, ty = dy - dn * uy, tz = dz - dn * uz;
    float tl = sqrt(tx * tx + ty * ty + tz * tz), dn2 = dn * dn;
    if (dn2 < L2 && tl > 1e-12) {
        float k = sqrt(L2 - dn2) / tl;
        return vec3(p.x + (ux * dn + tx * k), p.y + (uy * dn + ty * k), p.z + (uz * dn + tz * k));
    }
    float len = sqrt(dx * dx + dy * dy + dz * dz);
    float k = L / max(len, 1e-12);
    return len > 1e-12 ? vec3(p.x + dx * k, p.y + dy * k, p.z + dz * k) : c;
}

// The colliders the chunk can reach at this level, in the C backend's order: those whose box
// overlaps the chunk's box of positions and parents (grown by the longest segment), then
// those overlapping the box grown by the colliders taken, until nothing changes. Every
// invocation of the workgroup calls it with the same box buffer b (it synchronises); buffer b
// must have been reset before the previous barrier; thread 0 resets buffer `next`. hit[]
// receives indices into F.col.
uint chunk_colliders(bool live, vec3 c, vec3 p, uint k, uint b, uint next, out uint hit[MAX_COLLIDERS], out bool sdf)
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
    // the distance grid: a grid that holds no point changes nothing, so the grown box is as good
    sdf = F.sdf_dims.w != 0u && (!finite || (all(lessThanEqual(lo, F.sub[k].hi.xyz)) && all(greaterThanEqual(hi, F.sub[k].lo.xyz))));
    return nhit;
}

// The chain state of one strand between levels.
struct Chain {
    vec3 p;    // previous level's final position
    vec3 o;    // previous level's position at the substep start
    vec3 gp;   // the level before it: final position
    vec3 go;   // and position at the substep start
    vec3 pr;   // previous level's rest position
    vec4 q;    // previous level's frame
    vec3 pv;   // final velocity of the last finalised level (the root's, then level l - 2's)
    float f;   // previous level's share taken by the length projection's damping (ftl_damp)
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
    ch.f = 0.0;
    ch.o = ch.p;
    if (live) {
        ch.o = ldX(s);
        ch.pv = (ch.p - ch.o) * F.inv_dt_k;
        stV(s, ch.pv);
        stX(s, ch.p);
    }
    ch.gp = vec3(0.0);
    ch.go = vec3(0.0);
    ch.q = hd.rot;
    ch.bad = !finite3(ch.p);
    return ch;
}

// x carried by the head's (the colliders') rigid motion over substep k.
vec3 carry_point(vec3 x, uint k)
{
    vec4 c0 = F.sub[k].carry[0], c1 = F.sub[k].carry[1], c2 = F.sub[k].carry[2];
    return vec3(c0.x * x.x + c0.y * x.y + c0.z * x.z + c0.w, c1.x * x.x + c1.y * x.y + c1.z * x.z + c1.w,
                c2.x * x.x + c2.y * x.y + c2.z * x.z + c2.w);
}

// segment_carry of sim_cpu_chain.c: x carried rigidly by the parent's segment over the substep.
vec3 segment_carry(Chain ch, vec3 x)
{
    vec3 a = ch.o - ch.go, b = ch.p - ch.gp;
    a = a * (1.0 / sqrt(max(a.x * a.x + a.y * a.y + a.z * a.z, 1e-30)));
    b = b * (1.0 / sqrt(max(b.x * b.x + b.y * b.y + b.z * b.z, 1e-30)));
    vec3 kk = vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
    float co = a.x * b.x + a.y * b.y + a.z * b.z;
    vec3 v = x - ch.o;
    float kv = (kk.x * v.x + kk.y * v.y + kk.z * v.z) / max(1.0 + co, 1e-6);
    return ch.p + v * co + vec3(kk.y * v.z - kk.z * v.y, kk.z * v.x - kk.x * v.z, kk.x * v.y - kk.y * v.x) + kk * kv;
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
    vec4 w = F.stiff[l];
    vec3 rl = live ? ldRest(i) : vec3(0.0);
    vec3 xo = live ? ldX(i) : vec3(0.0);
    vec3 xs = pred;
    // each shape spring pulls toward its target, its damper toward the start carried by the
    // target's frame (level_constraints of sim_cpu_chain.c)
    vec3 hc = carry_point(xo, k);
    xs += w.x * ((qrot(hd.rot, rl) + hd.pos.xyz) - xs) + w.y * (hc - xs);
    // the DFTL correction carries the local-shape and inextensibility corrections (not the
    // global pull, whose reaction is the head's) to the parent
    vec3 xg = xs;
    vec3 r = rl - ch.pr;
    vec3 tgt = ch.p + qrot(ch.q, r);
    vec3 lc = l > 1u ? segment_carry(ch, xo) : hc;
    xs += w.z * (tgt - xs) + w.w * (lc - xs);
    float L = v3len(r);
    vec3 dd = ch.p - xs;
    float len = v3len(dd);
    float kl = L / max(len, 1e-12);
    xs = len > 1e-12 ? ch.p - dd * kl : tgt;
    float cf = min(max(1.0 - kl, 0.0) * F.ftl_damp, 1.0);
    vec3 delta = xs - xg;
    if (contacts_on()) { // collide_level of sim_cpu_chain.c
        uint hit[MAX_COLLIDERS];
        bool sdf;
        uint nhit = chunk_colliders(live, xs, ch.p, k, b, next, hit, sdf);
        if (nhit > 0u || sdf) {
            vec3 n = vec3(0.0);
            for (uint it = 0u; it < COLLISION_ITERATIONS; it++) {
                vec3 s0 = xs;
                for (uint h = 0u; h < nhit; h++) {
                    xs = collide_one(xs, hit[h]);
                    xs = collide_mid(ch.p, xs, hit[h], k);
                }
                if (sdf) {
                    xs = sdf_push(xs, k, SDF_SKIN);
                    xs = collide_mid(ch.p, xs, ~0u, k);
                }
                n = n + (xs - s0);
                xs = contact_slide(ch.p, xs, r, n);
                if (it == 0u) {
                    xs = contact_friction(xs, n, xo, k);
                    xs = contact_slide(ch.p, xs, r, n);
                }
            }
        }
    }
    if (live && l > 1u) {
        uint j = i - NS;
        vec3 v = (ch.p - ch.o) * F.inv_dt_k - F.dftl * delta * F.inv_dt_k;
        float kf = F.accel.w * (1.0 - ch.f);
        ch.pv = ch.pv + kf * (v - ch.pv); // internal damping toward the parent's velocity
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
    ch.gp = ch.p;
    ch.go = ch.o;
    ch.p = xs;
    ch.o = xo;
    ch.pr = rl;
    ch.f = cf;
}

// Finalises the last level of strand s; a strand that saw a non-finite value goes back to
// its rest pose under the substep's head transform and is counted.
void chain_finish(uint s, uint k, Chain ch)
{
    uint i = (NV - 1u) * NS + s;
    vec3 v = (ch.p - ch.o) * F.inv_dt_k;
    float kf = F.accel.w * (1.0 - ch.f);
    stV(i, ch.pv + kf * (v - ch.pv));
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
