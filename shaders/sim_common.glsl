// shaders: buffers, frame parameters and math shared by the solver's compute shaders.
// Layouts mirror server/sim/vk/sim_vk_internal.h and sim_vk_frame.h; the math mirrors
// server/core/math3.h and the C backend (server/sim/sim_cpu*.c) operation for operation.

const uint MAX_SUBSTEPS = 16u;
const uint MAX_COLLIDERS = 32u;
const uint MAX_NEIGHBORS = 64u;

// Collision / rest-length alternations per vertex, then final passes over the colliders
// (sim_cpu_chain.c COLLISION_ITERATIONS, CREVICE_PASSES).
const uint COLLISION_ITERATIONS = 1u;
const uint CREVICE_PASSES = 2u;

const uint FLAG_SHAPE = 1u;
const uint FLAG_SPH = 2u;
const uint FLAG_COLLISIONS = 4u;

layout(constant_id = 1) const uint NS = 1u; // strands
layout(constant_id = 2) const uint NV = 2u; // vertices per strand

struct Xf {
    vec4 pos; // xyz
    vec4 rot; // quaternion (x, y, z, w)
};

struct Collider {
    vec4 a;         // xyz: centre or segment start (world, this substep); w: kind 0 sphere, 1 capsule, 2 ellipsoid
    vec4 b;         // xyz: segment end; w: radius (sphere, capsule)
    vec4 radii;     // ellipsoid semi-axes
    vec4 inv_radii; // 1 / radii
    vec4 rot;       // ellipsoid orientation (world)
};

// Per-step parameters (host-computed, so the derived values have the C backend's bits).
layout(std430, set = 0, binding = 0) readonly buffer FrameBuf {
    vec4 accel;        // gravity + wind (xyz)
    float dt_k;        // substep length
    float inv_dt_k;    // 1 / dt_k
    float damping;     // s_d
    float h;           // SPH smoothing length
    float h2;          // h * h
    float inv_h2;      // 1 / h2
    float inv_h;       // 1 / h
    float kp;          // repulsion * h * 3600
    float mu_dt;       // viscosity * step dt
    float inv_step_dt; // 1 / step dt
    float inv_rho0;    // 1 / (rest_density * rest-pose mean density)
    float pad0;
    uint substeps;
    uint ncolliders;   // 0 when collisions are off
    uint flags;        // FLAG_*
    uint cap;          // SPH neighbours kept
    Xf head[MAX_SUBSTEPS];
    Collider col[MAX_SUBSTEPS * MAX_COLLIDERS];
    vec2 stiff[];      // (s_g, s_l) per level
} F;

// Particle arrays, level-major (i = level * NS + strand), 3 packed floats per particle.
layout(std430, set = 0, binding = 1) buffer XBuf { float d[]; } X;
layout(std430, set = 0, binding = 2) buffer VBuf { float d[]; } V;
layout(std430, set = 0, binding = 3) buffer ABuf { float d[]; } A;
layout(std430, set = 0, binding = 4) readonly buffer RestBuf { float d[]; } REST;
// Per strand: [2s] = last solved position (xyz), [2s + 1] = frame quaternion.
layout(std430, set = 0, binding = 5) buffer StrandBuf { vec4 d[]; } STRAND;

layout(std430, set = 0, binding = 18) buffer StatsBuf {
    uint nan_resets;
    uint pad[3];
} STATS;

layout(push_constant) uniform Push {
    uint substep;
    uint level;
    uint arg0;
    uint arg1;
} PC;

vec3 ldX(uint i) { return vec3(X.d[3u * i], X.d[3u * i + 1u], X.d[3u * i + 2u]); }
vec3 ldV(uint i) { return vec3(V.d[3u * i], V.d[3u * i + 1u], V.d[3u * i + 2u]); }
vec3 ldA(uint i) { return vec3(A.d[3u * i], A.d[3u * i + 1u], A.d[3u * i + 2u]); }
vec3 ldRest(uint i) { return vec3(REST.d[3u * i], REST.d[3u * i + 1u], REST.d[3u * i + 2u]); }
void stX(uint i, vec3 v) { X.d[3u * i] = v.x; X.d[3u * i + 1u] = v.y; X.d[3u * i + 2u] = v.z; }
void stV(uint i, vec3 v) { V.d[3u * i] = v.x; V.d[3u * i + 1u] = v.y; V.d[3u * i + 2u] = v.z; }
void stA(uint i, vec3 v) { A.d[3u * i] = v.x; A.d[3u * i + 1u] = v.y; A.d[3u * i + 2u] = v.z; }

// ---- math3.h ------------------------------------------------------------------------
float v3len(vec3 a) { return sqrt(a.x * a.x + a.y * a.y + a.z * a.z); }
vec3 v3norm(vec3 a)
{
    float l = v3len(a);
    return l > 0.0 ? a * (1.0 / l) : vec3(0.0);
}
vec4 qmul(vec4 a, vec4 b)
{
    return vec4(a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
                a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
                a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
                a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z);
}
vec4 qconj(vec4 q) { return vec4(-q.xyz, q.w); }
vec4 qnorm(vec4 q)
{
    float l = sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
    if (!(l > 0.0)) return vec4(0.0, 0.0, 0.0, 1.0);
    return vec4(q.x / l, q.y / l, q.z / l, q.w / l);
}
vec3 qrot(vec4 q, vec3 v)
{
    vec3 u = q.xyz;
    vec3 t = cross(u, v) * 2.0;
    return (v + t * q.w) + cross(u, t);
}
vec3 xf_point(Xf x, vec3 p) { return qrot(x.rot, p) + x.pos.xyz; }

// A float is finite when its exponent is not all ones (independent of fast-math folding).
bool finite3(vec3 v)
{
    uvec3 e = floatBitsToUint(v) & 0x7f800000u;
    return all(notEqual(e, uvec3(0x7f800000u)));
}

// ---- the chain (port of sim_cpu_chain.c) ------------------------------------------------

// Pushes p out of one collider onto its surface.
vec3 collide_one(vec3 p, Collider w)
{
    uint kind = uint(w.a.w);
    if (kind == 2u) {
        vec3 u = qrot(qconj(w.rot), p - w.a.xyz);
        vec3 sc = u * w.inv_radii.xyz;
        float sl = v3len(sc);
        if (!(sl < 1.0)) return p;
        float k = 1.0 / max(sl, 1e-12);
        vec3 q = sl < 1e-12 ? qrot(w.rot, vec3(0.0, w.radii.y, 0.0)) : qrot(w.rot, u * k);
        return w.a.xyz + q;
    }
    vec3 e = kind == 1u ? w.b.xyz - w.a.xyz : vec3(0.0);
    float ee = e.x * e.x + e.y * e.y + e.z * e.z;
    float inv_ee = kind == 1u && ee > 0.0 ? 1.0 / ee : 0.0;
    vec3 d0 = p - w.a.xyz;
    float t = (d0.x * e.x + d0.y * e.y + d0.z * e.z) * inv_ee;
    t = min(max(t, 0.0), 1.0);
    vec3 c = w.a.xyz + e * t;
    vec3 d = p - c;
    float dl = v3len(d);
    float r = w.b.w;
    if (!(dl < r)) return p;
    float k = r / max(dl, 1e-12);
    return vec3(c.x + d.x * k, dl < 1e-12 ? c.y + r : c.y + d.y * k, c.z + d.z * k);
}

vec3 collide_all(vec3 p, uint k)
{
    for (uint c = 0u; c < F.ncolliders; c++) p = collide_one(p, F.col[k * MAX_COLLIDERS + c]);
    return p;
}

// Follow the leader: puts c at distance |r| from p (unchanged when c sits on p).
vec3 follow(vec3 p, vec3 c, vec3 r)
{
    float L = v3len(r);
    vec3 dd = p - c;
    float len = v3len(dd);
    return len > 1e-12 ? p - dd * (L / max(len, 1e-12)) : c;
}

// The chain state of one strand between levels.
struct Chain {
    vec3 p;    // previous level's final position
    vec3 o;    // previous level's position at the substep start
    vec3 pr;   // previous level's rest position
    vec4 q;    // previous level's frame
    bool bad;  // a non-finite position was seen
};

// Kinematic root of strand s at substep k: writes its x and v, returns the chain start.
Chain chain_root(uint s, uint k)
{
    Xf hd = F.head[k];
    Chain ch;
    ch.pr = ldRest(s);
    ch.p = xf_point(hd, ch.pr);
    stV(s, (ch.p - ldX(s)) * F.inv_dt_k);
    stX(s, ch.p);
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
// correction (14) and moves the chain state on to level l.
void chain_solve(uint s, uint l, uint k, vec3 pred, inout Chain ch)
{
    Xf hd = F.head[k];
    uint i = l * NS + s;
    vec2 sgl = F.stiff[l];
    vec3 rl = ldRest(i);
    vec3 xo = ldX(i);
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
        for (uint it = 0u; it < COLLISION_ITERATIONS; it++) {
            xs = collide_all(xs, k);
            xs = follow(ch.p, xs, r);
        }
        for (uint pass = 0u; pass < CREVICE_PASSES; pass++) xs = collide_all(xs, k);
    }
    if (l > 1u) {
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
