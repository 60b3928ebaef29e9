// shaders: buffers, frame parameters and math shared by the solver's compute shaders.
// Layouts mirror server/sim/vk/sim_vk_internal.h (sim_vk_frame.c checks them); the math mirrors
// server/core/math3.h and the C backend (server/sim/sim_cpu*.c) operation for operation.

#include "sim_limits.h"

const uint MAX_SUBSTEPS = uint(SIM_MAX_SUBSTEPS);
const uint MAX_COLLIDERS = uint(SIM_MAX_COLLIDERS);
const uint MAX_NEIGHBORS = uint(SIM_MAX_NEIGHBOR_CAP);
const uint COLLISION_ITERATIONS = uint(SIM_COLLISION_ITERATIONS);
const float SDF_SKIN = float(SIM_SDF_SKIN);

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
    vec4 a;      // xyz: centre or segment start (world, this substep); w: kind 0 sphere, 1 capsule, 2 ellipsoid
    vec4 b;      // xyz: segment end; w: radius (sphere, capsule)
    vec4 lo;     // world bounding box (culling)
    vec4 hi;
    vec4 m[3];   // ellipsoid: rows of world offset -> unit-sphere coordinates
    vec4 nrm[3]; // ellipsoid: rows of unit-sphere coordinates -> world offset
};

// Per substep (sim_step_desc.carry, .wsdf).
struct Sub {
    vec4 carry[3];     // rows (xyz matrix, w translation): the colliders' motion over the substep
    vec4 to_head[3];   // rows: world offset from pos -> head frame (the distance grid's frame)
    vec4 from_head[3]; // rows: head-frame direction -> world
    vec4 pos;          // head position
    vec4 lo;           // world box of the distance grid (culling)
    vec4 hi;
};

// Per-step parameters: the host's sim_step_desc (server/sim/sim_step.h), so the derived values
// have the C backend's bits.
layout(std430, set = 0, binding = 0) restrict readonly buffer FrameBuf {
    vec4 accel;        // xyz: gravity + wind; w: keep = exp(-damping dt_k) (sim_step.h)
    float dt_k;        // substep length
    float inv_dt_k;    // 1 / dt_k
    float dftl;        // s_d
    float h;           // SPH smoothing length
    float h2;          // h * h
    float inv_h2;      // 1 / h2
    float inv_h;       // 1 / h
    float kp;          // repulsion * rest_density * h * hold (sim_step.h)
    float mu_dt;       // viscosity * step dt
    float inv_step_dt; // 1 / step dt
    float inv_rho0;    // 1 / (rest_density * rest-pose mean density)
    float grow;        // longest rest segment (collider culling margin)
    uint substeps;
    uint ncolliders;   // 0 when collisions are off
    uint flags;        // FLAG_*
    uint cap;          // SPH neighbours kept
    float drag_keep;   // exp(-air_drag dt_k)
    float friction;    // contact friction
    float sph_keep;    // share of the previous step's SPH acceleration kept (sim_step.h)
    float sph_inv_since; // 1 / time since the last SPH evaluation, 0 without one (sim_step.h)
    float hair_friction; // hair-hair static friction (sim_step.h)
    float ftl_damp;    // the length projection's extra damping (sim_step.h)
    float pad1, pad2;
    Xf head[MAX_SUBSTEPS];
    Collider col[MAX_SUBSTEPS * MAX_COLLIDERS];
    uvec4 sdf_dims;    // xyz: samples per axis of the distance grid; w: 1 when it collides
    vec4 sdf_origin;   // xyz: position of sample (0,0,0), head frame; w: cell
    Sub sub[MAX_SUBSTEPS];
    vec4 stiff[];      // shape weights per level (sim_shape_weights: g, gd, l, ld)
} F;

// Particle arrays, level-major (i = level * NS + strand), 3 packed floats per particle.
layout(std430, set = 0, binding = 1) restrict buffer XBuf { float d[]; } X;
layout(std430, set = 0, binding = 2) restrict buffer VBuf { float d[]; } V;
layout(std430, set = 0, binding = 3) restrict buffer ABuf { float d[]; } A;
layout(std430, set = 0, binding = 4) restrict readonly buffer RestBuf { float d[]; } REST;
// Per strand: [3s] = last solved position (xyz, w: non-finite seen), [3s + 1] = frame
// quaternion, [3s + 2] = final velocity of the last finalised level (xyz).
layout(std430, set = 0, binding = 5) restrict buffer StrandBuf { vec4 d[]; } STRAND;

layout(std430, set = 0, binding = 18) restrict buffer StatsBuf {
    uint nan_resets;
    uint pbd_stretch; // the PBD solver's largest relative stretch left to its closing pass (float bits)
    uint stretch_lo, stretch_hi; // the PBD solver's stretch sum in SIM_PBD_STRETCH_UNIT, 64 bits
} STATS;

// The groom's distance grid (core_sdf.d: x fastest, then y, then z), or one unused word.
layout(std430, set = 0, binding = 19) restrict readonly buffer SdfBuf { float d[]; } SDF;

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

// Order-preserving uint encoding of a float (for atomic min/max) and back.
uint fkey(float f)
{
    uint u = floatBitsToUint(f);
    return (u & 0x80000000u) != 0u ? ~u : u | 0x80000000u;
}
float keyf(uint k) { return uintBitsToFloat((k & 0x80000000u) != 0u ? k & 0x7fffffffu : ~k); }

// a > 0 ? a : 0 (the C backend's MAX0).
float max0(float a) { return a > 0.0 ? a : 0.0; }

// A float is finite when its exponent is not all ones (independent of fast-math folding).
bool finite3(vec3 v)
{
    uvec3 e = floatBitsToUint(v) & 0x7f800000u;
    return all(notEqual(e, uvec3(0x7f800000u)));
}

