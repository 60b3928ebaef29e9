/* core: small 3D vector, quaternion and rigid-transform math (header-only, pure). */
#ifndef CORE_MATH3_H
#define CORE_MATH3_H

#include <math.h>

typedef struct core_vec3 { float x, y, z; } core_vec3;
/* Unit quaternion, w is the scalar part. */
typedef struct core_quat { float x, y, z, w; } core_quat;
/* Rigid transform: p_world = rot * p_local + pos. */
typedef struct core_xform { core_vec3 pos; core_quat rot; } core_xform;

static inline core_vec3 core_v3(float x, float y, float z) { core_vec3 r = { x, y, z }; return r; }
static inline core_vec3 core_v3_add(core_vec3 a, core_vec3 b) { return core_v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline core_vec3 core_v3_sub(core_vec3 a, core_vec3 b) { return core_v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline core_vec3 core_v3_scale(core_vec3 a, float s) { return core_v3(a.x * s, a.y * s, a.z * s); }
static inline float core_v3_dot(core_vec3 a, core_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline float core_v3_len(core_vec3 a) { return sqrtf(core_v3_dot(a, a)); }
static inline core_vec3 core_v3_cross(core_vec3 a, core_vec3 b)
{
    return core_v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline core_vec3 core_v3_lerp(core_vec3 a, core_vec3 b, float t)
{
    return core_v3(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, a.z + (b.z - a.z) * t);
}
static inline core_vec3 core_v3_norm(core_vec3 a)
{
    float l = core_v3_len(a);
    return l > 0.0f ? core_v3_scale(a, 1.0f / l) : core_v3(0.0f, 0.0f, 0.0f);
}

static inline core_quat core_q_identity(void) { core_quat q = { 0.0f, 0.0f, 0.0f, 1.0f }; return q; }
static inline core_quat core_q_mul(core_quat a, core_quat b)
{
    core_quat r = {
        a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
        a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
        a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
        a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
    };
    return r;
}
static inline core_quat core_q_conj(core_quat q) { core_quat r = { -q.x, -q.y, -q.z, q.w }; return r; }
static inline core_quat core_q_norm(core_quat q)
{
    float l = sqrtf(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
    if (!(l > 0.0f)) return core_q_identity();
    core_quat r = { q.x / l, q.y / l, q.z / l, q.w / l };
    return r;
}
/* Rotation by angle (radians) about a unit axis. */
static inline core_quat core_q_axis_angle(core_vec3 axis, float angle)
{
    float s = sinf(0.5f * angle);
    core_quat q = { axis.x * s, axis.y * s, axis.z * s, cosf(0.5f * angle) };
    return q;
}
/* v' = q v q^-1 for a unit quaternion. */
static inline core_vec3 core_q_rotate(core_quat q, core_vec3 v)
{
    core_vec3 u = core_v3(q.x, q.y, q.z);
    core_vec3 t = core_v3_scale(core_v3_cross(u, v), 2.0f);
    return core_v3_add(core_v3_add(v, core_v3_scale(t, q.w)), core_v3_cross(u, t));
}
/* Normalized linear interpolation along the shorter arc. */
static inline core_quat core_q_nlerp(core_quat a, core_quat b, float t)
{
    float d = a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w;
    float s = d < 0.0f ? -1.0f : 1.0f;
    core_quat r = { a.x + (s * b.x - a.x) * t, a.y + (s * b.y - a.y) * t,
                    a.z + (s * b.z - a.z) * t, a.w + (s * b.w - a.w) * t };
    return core_q_norm(r);
}

static inline core_xform core_xform_identity(void)
{
    core_xform x = { { 0.0f, 0.0f, 0.0f }, { 0.0f, 0.0f, 0.0f, 1.0f } };
    return x;
}
static inline core_vec3 core_xform_point(core_xform x, core_vec3 p) { return core_v3_add(core_q_rotate(x.rot, p), x.pos); }
static inline core_xform core_xform_lerp(core_xform a, core_xform b, float t)
{
    core_xform r = { core_v3_lerp(a.pos, b.pos, t), core_q_nlerp(a.rot, b.rot, t) };
    return r;
}

#endif
