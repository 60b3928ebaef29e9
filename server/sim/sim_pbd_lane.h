/* sim: SIM_PBD_LANES floats as one value (GCC/Clang vector extensions) and the 3-vector
 * arithmetic of core/math3.h on them, element by element in the same order, so a lane's result
 * is the bits the scalar code gives (private to sim_pbd_solve.c). */
#ifndef SIM_SIM_PBD_LANE_H
#define SIM_SIM_PBD_LANE_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "sim_pbd_internal.h"

typedef float sim_lane __attribute__((vector_size(4 * SIM_PBD_LANES)));
typedef int32_t sim_lane_mask __attribute__((vector_size(4 * SIM_PBD_LANES)));

typedef struct sim_lv3 {
    sim_lane x, y, z;
} sim_lv3;

static inline sim_lane sim_lane_ld(const float *a)
{
    sim_lane v;
    memcpy(&v, a, sizeof v);
    return v;
}

static inline void sim_lane_st(float *a, sim_lane v) { memcpy(a, &v, sizeof v); }

/* Per lane: m ? a : b (m from a comparison: all bits set or clear). */
static inline sim_lane sim_lane_sel(sim_lane_mask m, sim_lane a, sim_lane b)
{
    return (sim_lane)((m & (sim_lane_mask)a) | (~m & (sim_lane_mask)b));
}

static inline sim_lane sim_lane_sqrt(sim_lane a)
{
    sim_lane r = a;
    for (int j = 0; j < SIM_PBD_LANES; j++) r[j] = sqrtf(a[j]);
    return r;
}

static inline sim_lane sim_lane_splat(float f)
{
    sim_lane r = { 0 };
    for (int j = 0; j < SIM_PBD_LANES; j++) r[j] = f;
    return r;
}

/* Vertex l of a lane-minor array (component d of lane j at (3 l + d) SIM_PBD_LANES + j). */
static inline sim_lv3 sim_lv3_ld(const float *a, uint32_t l)
{
    const float *q = a + 3 * (size_t)l * SIM_PBD_LANES;
    return (sim_lv3){ sim_lane_ld(q), sim_lane_ld(q + SIM_PBD_LANES), sim_lane_ld(q + 2 * SIM_PBD_LANES) };
}

static inline void sim_lv3_st(float *a, uint32_t l, sim_lv3 v)
{
    float *q = a + 3 * (size_t)l * SIM_PBD_LANES;
    sim_lane_st(q, v.x);
    sim_lane_st(q + SIM_PBD_LANES, v.y);
    sim_lane_st(q + 2 * SIM_PBD_LANES, v.z);
}

static inline sim_lv3 sim_lv3_add(sim_lv3 a, sim_lv3 b) { return (sim_lv3){ a.x + b.x, a.y + b.y, a.z + b.z }; }
static inline sim_lv3 sim_lv3_sub(sim_lv3 a, sim_lv3 b) { return (sim_lv3){ a.x - b.x, a.y - b.y, a.z - b.z }; }
static inline sim_lv3 sim_lv3_scale(sim_lv3 a, sim_lane s) { return (sim_lv3){ a.x * s, a.y * s, a.z * s }; }
static inline sim_lane sim_lv3_dot(sim_lv3 a, sim_lv3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

static inline sim_lv3 sim_lv3_cross(sim_lv3 a, sim_lv3 b)
{
    return (sim_lv3){ a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x };
}

static inline sim_lv3 sim_lv3_splat(core_vec3 a)
{
    return (sim_lv3){ sim_lane_splat(a.x), sim_lane_splat(a.y), sim_lane_splat(a.z) };
}

/* core_q_rotate of every lane by q. */
static inline sim_lv3 sim_lv3_q_rotate(core_quat q, sim_lv3 v)
{
    const sim_lv3 u = sim_lv3_splat(core_v3(q.x, q.y, q.z));
    const sim_lv3 t = sim_lv3_scale(sim_lv3_cross(u, v), sim_lane_splat(2.0f));
    return sim_lv3_add(sim_lv3_add(v, sim_lv3_scale(t, sim_lane_splat(q.w))), sim_lv3_cross(u, t));
}

#endif
