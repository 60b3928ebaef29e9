// shaders: one PBD substep (port of strand_substep in server/sim/sim_pbd_solve.c, operation for
// operation), one thread per strand: Verlet prediction, pbd_iterations rounds of the angular
// constraints (three phases), the global pull, the distance constraints (even, then odd
// segments) and the collisions, then friction, the exact root-to-tip distance pass with the
// contacts and the velocities (DFTL correction, internal damping), and the reset of a strand
// that went non-finite. F.stiff[l] holds (kg, kl, b, 0) for this solver.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_collide.glsl"

layout(local_size_x_id = 0) in;

// Per-vertex scratch of the substep (the C solver's strand_view), field-major, each field
// level-major like X: 3 floats per vertex.
layout(std430, set = 0, binding = 20) restrict buffer PbdBuf { float d[]; } P;

// Per vertex, level-major like X: the distance from the grid's surface a push lifts it to
// (sim_groom_contact_floor).
layout(std430, set = 0, binding = 21) restrict readonly buffer FloorBuf { float d[]; } FLOOR;

const uint NP = NS * NV;
const uint P_O = 0u;    // position at the substep's start
const uint P_SEG = 1u;  // rest segment ending at the level, under the head
const uint P_E0 = 2u;   // unit rest direction of the segment before it, under the head
const uint P_GT = 3u;   // global target
const uint P_GC = 4u;   // start carried by the head
const uint P_EO = 5u;   // unit start direction of the segment before it
const uint P_OD = 6u;   // start segment ending at the level
const uint P_LG = 7u;   // XPBD multiplier of the global constraint
const uint P_LL = 8u;   // XPBD multiplier of the angular constraint
const uint P_PUSH = 9u; // sum of the collision pushes

uint pidx(uint f, uint l, uint s) { return 3u * (f * NP + l * NS + s); }
vec3 ldP(uint f, uint l, uint s)
{
    uint i = pidx(f, l, s);
    return vec3(P.d[i], P.d[i + 1u], P.d[i + 2u]);
}
void stP(uint f, uint l, uint s, vec3 v)
{
    uint i = pidx(f, l, s);
    P.d[i] = v.x;
    P.d[i + 1u] = v.y;
    P.d[i + 2u] = v.z;
}
vec3 ldx(uint l, uint s) { return ldX(l * NS + s); }
void stx(uint l, uint s, vec3 v) { stX(l * NS + s, v); }

float dot3(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
float len3(vec3 a) { return sqrt(dot3(a, a)); }
vec3 cross3(vec3 a, vec3 b) { return vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x); }
// core_q_rotate
vec3 qrot3(vec4 q, vec3 v)
{
    vec3 u = q.xyz;
    vec3 t = cross3(u, v) * 2.0;
    return (v + t * q.w) + cross3(u, t);
}
vec3 xf_point3(Xf x, vec3 p) { return qrot3(x.rot, p) + x.pos.xyz; }

// Rotates v by the minimal rotation taking unit a onto unit b.
vec3 min_rotate(vec3 a, vec3 b, vec3 v)
{
    vec3 k = cross3(a, b);
    float co = dot3(a, b);
    float kv = dot3(k, v) / max(1.0 + co, 1e-6);
    return (v * co + cross3(k, v)) + k * kv;
}

vec3 unit(vec3 a)
{
    float l2 = dot3(a, a);
    return l2 > 1e-30 ? a * (1.0 / sqrt(l2)) : vec3(0.0, 1.0, 0.0);
}

// Where the colliders' rigid motion over substep k takes p.
vec3 carry(uint k, vec3 p)
{
    vec4 c0 = F.sub[k].carry[0], c1 = F.sub[k].carry[1], c2 = F.sub[k].carry[2];
    return vec3(c0.x * p.x + c0.y * p.y + c0.z * p.z + c0.w, c1.x * p.x + c1.y * p.y + c1.z * p.z + c1.w,
                c2.x * p.x + c2.y * p.y + c2.z * p.z + c2.w);
}

// The XPBD projection of x - t = 0 on vertex l with multiplier field lf; the parent at level
// l - 1 (when parent) takes wp of the reaction (pull of sim_pbd_solve.c).
void pull(uint l, uint s, bool parent, float wp, vec3 t, vec3 xc, float w, float c, uint lf)
{
    float inv_den = 1.0 / (1.0 + (w + c) * (1.0 + wp));
    vec3 x = ldx(l, s), lam = ldP(lf, l, s);
    vec3 dl = (w * (t - x) - c * (x - xc) - lam) * inv_den;
    stP(lf, l, s, lam + dl);
    stx(l, s, x + dl);
    if (parent) stx(l - 1u, s, ldx(l - 1u, s) - wp * dl);
}

void angular(uint l, uint s, float h, float b)
{
    float kl = F.stiff[l].y;
    if (!(kl > 0.0)) return;
    float w = kl * h * h, c = kl * h * b;
    vec3 seg = ldP(P_SEG, l, s), parent = ldx(l - 1u, s);
    vec3 t, xc;
    if (l == 1u) {
        t = parent + seg;
        xc = ldP(P_GC, 1u, s);
    } else {
        vec3 e1 = unit(parent - ldx(l - 2u, s));
        t = parent + min_rotate(ldP(P_E0, l, s), e1, seg);
        xc = parent + min_rotate(ldP(P_EO, l, s), e1, ldP(P_OD, l, s));
    }
    pull(l, s, true, l == 1u ? 0.0 : 1.0, t, xc, w, c, P_LL);
}

// The distance constraint of the segment ending at level l (the root does not move).
void distance(uint l, uint s)
{
    vec3 a = ldx(l - 1u, s), bb = ldx(l, s);
    vec3 d = bb - a;
    float dl = len3(d);
    if (!(dl > 1e-12)) return;
    float wa = l == 1u ? 0.0 : 0.5, wb = 1.0 - wa;
    float rest = len3(ldRest(l * NS + s) - ldRest((l - 1u) * NS + s));
    vec3 n = d * ((dl - rest) / dl);
    stx(l - 1u, s, a + n * wa);
    stx(l, s, bb - n * wb);
}

// push_collider of sim_pbd_solve.c: the box test, then collide_one.
vec3 push_collider(uint ci, vec3 x)
{
    vec3 lo = F.col[ci].lo.xyz, hi = F.col[ci].hi.xyz;
    if (x.x < lo.x || x.x > hi.x || x.y < lo.y || x.y > hi.y || x.z < lo.z || x.z > hi.z) return x;
    return collide_one(x, ci);
}

// push_sdf of sim_pbd_solve.c: the box test, then sdf_push to the vertex's contact floor.
vec3 push_grid(uint k, vec3 x, float target)
{
    vec3 lo = F.sub[k].lo.xyz, hi = F.sub[k].hi.xyz;
    if (x.x < lo.x || x.x > hi.x || x.y < lo.y || x.y > hi.y || x.z < lo.z || x.z > hi.z) return x;
    return sdf_push(x, k, target);
}

vec3 friction(vec3 x, vec3 n, vec3 oc, float mu)
{
    float nl = len3(n);
    if (!(nl > 0.0)) return x;
    vec3 u = n * (1.0 / nl), d = x - oc;
    vec3 t = d - u * dot3(d, u);
    float tl = len3(t), lim = mu * nl;
    return x - t * (tl <= lim ? 1.0 : lim / tl);
}

// slide of sim_pbd_solve.c: x at distance L from its parent p, keeping its offset along the
// contact normal n, moved on the tangent plane.
vec3 slide(vec3 x, vec3 p, float L, vec3 n)
{
    float nl = len3(n);
    if (!(nl > 0.0)) return x;
    vec3 u = n * (1.0 / nl), d = x - p;
    float dn = dot3(d, u);
    vec3 t = d - u * dn;
    float tl = len3(t);
    if (dn * dn < L * L && tl > 1e-12) return p + (u * dn + t * (sqrt(L * L - dn * dn) / tl));
    float dl = len3(d);
    return dl > 1e-12 ? p + d * (L / dl) : x;
}

// Vertex l's pushes out of the colliders, then out of the grid to its contact floor.
vec3 collide(uint k, uint l, uint s, vec3 x)
{
    for (uint c = 0u; c < F.ncolliders; c++) x = push_collider(k * MAX_COLLIDERS + c, x);
    if (F.sdf_dims.w != 0u) x = push_grid(k, x, FLOOR.d[l * NS + s]);
    return x;
}

// lane_velocity of sim_pbd_solve.c: vertex l's velocity, its start moved by s_d times its
// successor's correction c, then internal damping toward its parent's final velocity.
void velocity(uint l, uint s, vec3 c, float inv_h)
{
    vec3 o = ldP(P_O, l, s) + c * F.dftl;
    vec3 vn = (ldx(l, s) - o) * inv_h;
    vec3 pv = ldV((l - 1u) * NS + s);
    stV(l * NS + s, pv + (vn - pv) * F.accel.w);
}

// close_lengths of sim_pbd_solve.c: the exact root-to-tip distance pass, each vertex then
// pushed out, slid back to its length on the contact plane, friction and slid again; the
// velocities one level behind. Returns the largest relative stretch the iterations left and
// (sum) their sum.
float close_lengths(uint k, uint s, float inv_h, out float sum)
{
    float worst = 0.0;
    sum = 0.0;
    vec3 old = ldx(0u, s);
    for (uint l = 1u; l < NV; l++) {
        vec3 pa = ldx(l - 1u, s), pb = ldx(l, s);
        float L = len3(ldRest(l * NS + s) - ldRest((l - 1u) * NS + s));
        vec3 e = pb - old;
        float el = len3(e) - L;
        float r = abs(el) / (L > 0.0 ? L : 1.0);
        if (L > 0.0 && r > worst) worst = r;
        sum = sum + (L > 0.0 ? r : 0.0);
        old = pb;
        vec3 d = pb - pa;
        float dl = len3(d);
        vec3 x = dl > 1e-12 ? pa + d * (L / dl) : pb;
        vec3 y = collide(k, l, s, x);
        vec3 n = ldP(P_PUSH, l, s) + (y - x);
        stP(P_PUSH, l, s, n);
        y = slide(y, pa, L, n);
        if (F.friction > 0.0) y = slide(friction(y, n, ldP(P_GC, l, s), F.friction), pa, L, n);
        stx(l, s, y);
        if (l > 1u) velocity(l - 1u, s, x - pb, inv_h);
    }
    velocity(NV - 1u, s, vec3(0.0), inv_h);
    return worst;
}

// The per-substep fields from the starts and the rest pose (substep_frames).
void substep_frames(uint s, uint k)
{
    Xf head = F.head[k];
    for (uint l = 0u; l < NV; l++) {
        vec3 r = ldRest(l * NS + s), o = ldP(P_O, l, s);
        stP(P_GT, l, s, xf_point3(head, r));
        stP(P_GC, l, s, carry(k, o));
        if (l == 0u) continue;
        stP(P_SEG, l, s, qrot3(head.rot, r - ldRest((l - 1u) * NS + s)));
        stP(P_OD, l, s, o - ldP(P_O, l - 1u, s));
        if (l == 1u) continue;
        stP(P_E0, l, s, unit(ldP(P_SEG, l - 1u, s)));
        stP(P_EO, l, s, unit(ldP(P_OD, l - 1u, s)));
    }
}

void main()
{
    uint s = gl_GlobalInvocationID.x;
    if (s >= NS) return;
    uint k = PC.substep, iterations = PC.arg0;
    float h = F.dt_k, inv_h = F.inv_dt_k, b = F.stiff[0].z;
    Xf head = F.head[k];
    vec3 acc = F.accel.xyz;
    // the root follows the head; the others: Verlet with air drag
    vec3 root = xf_point3(head, ldRest(s));
    for (uint l = 0u; l < NV; l++) stP(P_O, l, s, ldx(l, s));
    stV(s, (root - ldx(0u, s)) * inv_h);
    stx(0u, s, root);
    for (uint l = 1u; l < NV; l++) {
        vec3 v = ldV(l * NS + s) * F.drag_keep;
        stx(l, s, ldx(l, s) + (v * h + acc * (h * h)));
    }
    substep_frames(s, k);
    for (uint l = 0u; l < NV; l++) {
        stP(P_LG, l, s, vec3(0.0));
        stP(P_LL, l, s, vec3(0.0));
        stP(P_PUSH, l, s, vec3(0.0));
    }
    for (uint it = 0u; it < iterations; it++) {
        for (uint phase = 0u; phase < 3u; phase++)
            for (uint l = 1u + phase; l < NV; l += 3u) angular(l, s, h, b);
        for (uint l = 1u; l < NV; l++) {
            float kg = F.stiff[l].x;
            if (!(kg > 0.0)) continue;
            pull(l, s, false, 0.0, ldP(P_GT, l, s), ldP(P_GC, l, s), kg * h * h, kg * h * b, P_LG);
        }
        for (uint l = 1u; l < NV; l += 2u) distance(l, s); // even segments (from vertex 0, 2, ...)
        for (uint l = 2u; l < NV; l += 2u) distance(l, s); // odd segments
        for (uint l = 1u; l < NV; l++) {
            vec3 before = ldx(l, s), x = collide(k, l, s, before);
            stx(l, s, x);
            stP(P_PUSH, l, s, ldP(P_PUSH, l, s) + (x - before));
        }
    }
    if (F.friction > 0.0)
        for (uint l = 1u; l < NV; l++) stx(l, s, friction(ldx(l, s), ldP(P_PUSH, l, s), ldP(P_GC, l, s), F.friction));
    float sum;
    float worst = close_lengths(k, s, inv_h, sum);
    if (worst > 0.0) atomicMax(STATS.pbd_stretch, floatBitsToUint(worst));
    uint q = uint((sum < float(SIM_PBD_STRETCH_CAP) ? sum : float(SIM_PBD_STRETCH_CAP)) * float(SIM_PBD_STRETCH_UNIT));
    if (q != 0u) {
        uint was = atomicAdd(STATS.stretch_lo, q);
        if (was + q < was) atomicAdd(STATS.stretch_hi, 1u);
    }
    bool ok = finite3(ldx(0u, s));
    for (uint l = 1u; l < NV; l++) ok = ok && finite3(ldV(l * NS + s)) && finite3(ldx(l, s));
    if (!ok) { // NaN or inf somewhere along the strand: back to its rest pose
        for (uint l = 0u; l < NV; l++) {
            stx(l, s, xf_point3(head, ldRest(l * NS + s)));
            stV(l * NS + s, vec3(0.0));
        }
        atomicAdd(STATS.nan_resets, 1u);
    }
}
