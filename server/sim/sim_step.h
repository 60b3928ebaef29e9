/* sim: the host-side description of one step (colliders in world space, substep heads,
 * per-level stiffness, scales) that every backend consumes, so a physics change is made once. */
#ifndef SIM_SIM_STEP_H
#define SIM_SIM_STEP_H

#include <stdbool.h>
#include <stdint.h>

#include "sim.h"
#include "sim_limits.h"

/* A collider moved to world space for one substep. */
typedef struct sim_wcollider {
    core_collider_kind kind;
    core_vec3 a, b;      /* world centre / segment ends */
    float radius;
    float lo[3], hi[3];  /* world bounding box, for culling */
    float axis[3];       /* capsule: b - a (zero for a sphere, which is a capsule of length 0) */
    float inv_axis2;     /* 1 / |axis|^2, 0 for a sphere */
    float to_unit[9];    /* ellipsoid: world offset -> unit-sphere coords (diag(1/r) R^T), row-major */
    float from_unit[9];  /* ellipsoid: unit-sphere coords -> world offset (R diag(r)), row-major */
} sim_wcollider;

/* A groom's distance grid (a collider moving rigidly with the head) placed for one substep. */
typedef struct sim_wsdf {
    float pos[3];       /* head position */
    float to_head[9];   /* world offset from pos -> head frame (R^T), row-major */
    float from_head[9]; /* head-frame direction -> world (R), row-major */
    float lo[3], hi[3]; /* world bounding box of the grid's box, for culling */
} sim_wsdf;

/* What a groom contributes to every step. */
typedef struct sim_groom_info {
    uint32_t ncolliders;
    const core_collider *colliders; /* head frame */
    const core_sdf *sdf;            /* distance grid in the head frame (dims, origin, cell; the
                                       samples only where a backend reads them), or NULL */
    float rho_rest;                 /* mean rest-pose SPH density (any positive value before it is known) */
    float sph_auto_h;               /* the groom's automatic smoothing length (sim_sph_auto_radius) */
} sim_groom_info;

/* One step of params.dt in `substeps` substeps of length h. */
typedef struct sim_step_desc {
    float dt, h, inv_h;       /* step, substep, 1 / substep */
    int substeps;
    float accel[3];           /* gravity + wind, m/s^2 */
    float dftl;               /* s_d: share of the child's local-shape and inextensibility correction
                                 taken off the parent's velocity (eq. 14) */
    float keep;               /* exp(-damping h): share of a vertex's velocity relative to its parent
                                 kept per substep */
    float drag_keep;          /* exp(-air_drag h): share of a vertex's velocity kept per substep */
    float ftl_damp;           /* max(SIM_FTL_DAMPING_STEP / h - 1, 0): the length projection's share
                                 delta / len of a vertex is taken this many times more off its
                                 velocity relative to its parent (at most all of it) */
    bool shape, sph, collisions;
    float sph_h;              /* smoothing length (sim_sph_radius) */
    float kp;                 /* repulsion * rest_density * h * hold, hold = SIM_SPH_ACCEL_SCALE
                                 (+ SIM_SPH_HOLD_GAIN * min(global_stiffness, SIM_SPH_HOLD_LOCAL_SHARE
                                 * local_stiffness) * stiffness_tip with shape on) */
    float mu_dt;              /* viscosity * dt */
    bool sph_eval;            /* this step evaluates SPH (sim_step_sph_clock); when false and sph,
                                 the held acceleration acts again */
    float sph_keep;           /* exp(-elapsed / SIM_SPH_SMOOTH_TIME) with shape on, elapsed the time
                                 since the last evaluation: share of the held SPH acceleration an
                                 evaluation keeps (0 with shape off, and when the backend has none:
                                 after a reset or a step without SPH) */
    float sph_inv_since;      /* 1 / the time since the last SPH evaluation when this step evaluates
                                 and the backend kept that evaluation's positions, else 0: the
                                 viscosity's velocities are the hair's motion over that time
                                 ((x - x at that evaluation) x this), not the solver's velocities,
                                 which carry the DFTL correction (eq. 14) even where nothing moves */
    float inv_rho0;           /* 1 / (rest_density * rest-pose mean density) */
    uint32_t ncolliders;      /* 0 when collisions are off */
    float friction;           /* contact friction (sim_params.friction) */
    float hair_friction;      /* hair-hair static friction (sim_params.hair_friction) */
    const core_sdf *sdf;      /* the groom's distance grid when collisions are on, else NULL */
    float carry[SIM_MAX_SUBSTEPS][12]; /* rows (m0 m1 m2 t) of the colliders' rigid motion over
                                          substep k: p at its start -> M p + t at its end */
    sim_wsdf wsdf[SIM_MAX_SUBSTEPS];   /* the distance grid under head[k] (when sdf) */
    core_xform head[SIM_MAX_SUBSTEPS];                     /* head at the end of substep k */
    sim_wcollider col[SIM_MAX_SUBSTEPS][SIM_MAX_COLLIDERS]; /* colliders under head[k] */
} sim_step_desc;

/* The automatic SPH smoothing length of g: SIM_SPH_AUTO_SPACINGS x the mean distance from a
 * root to the nearest other root, clamped to [SIM_SPH_MIN_H, SIM_SPH_MAX_H] (the largest for a
 * single strand). Allocates scratch (freed before returning; 3 mm when it cannot). Pure; any
 * thread; about n log n in the strand count. */
float sim_sph_auto_radius(const core_groom *g);

/* The smoothing length a step uses: p->sph_radius (at least SIM_SPH_MIN_H), or g's automatic
 * one when p->sph_radius is 0. Pure. */
float sim_sph_radius(const sim_params *p, const sim_groom_info *g);

/* True when the SPH stage has an effect (sph on, repulsion + viscosity > 0). Pure. */
bool sim_step_sph_on(const sim_params *p);

/* Fills out for one step of p (validated) from head transform prev_head to head (roots and
 * colliders interpolated across the substeps). Pure; any thread. */
void sim_step_plan(const sim_params *p, const sim_groom_info *g, core_xform prev_head, core_xform head,
                   sim_step_desc *out);

/* A backend's SPH evaluation clock: whether it holds an SPH acceleration and how many steps
 * have passed since it was evaluated. Zero = holds none. */
typedef struct sim_sph_clock {
    bool warm;
    uint32_t age;
} sim_sph_clock;
/* After sim_step_plan: decides whether this step evaluates SPH (out->sph_eval: when the
 * backend holds no acceleration, with shape off, or once 1 / SIM_SPH_RATE has passed since the
 * last evaluation, counted in whole steps) and sets out->sph_keep and out->sph_inv_since for the
 * time since the last one; advances clk (reset to zero when SPH is off). Pure apart from clk; the backend's step
 * thread. */
void sim_step_sph_clock(const sim_params *p, sim_sph_clock *clk, sim_step_desc *out);
/* The shape weights of one level for one substep: a vertex at s moves by
 * g (global target - s) + gd (its start carried by the head - s), then by
 * l (local target - s) + ld (its start carried by the parent's segment - s). */
typedef struct sim_shape_weights {
    float g, gd, l, ld;
} sim_shape_weights;

/* The shape springs' damper at substep h as a time b (s): a spring of stiffness k carries the
 * damper k b, (max(SIM_SHAPE_DAMPING_STEP - h, 0) + max(SIM_FTL_DAMPING_STEP - h, 0)) / 2. The
 * implicit step of spring and damper, (1 + k h^2 + k h b) x' = x + v h + k h b x for the offset x
 * from the target, keeps 1 / sqrt(1 + k h^2 + k h b) of a swing per substep: per unit of time a
 * decay rate ln(1 + k h^2 + k h b) / (2 h) = k (h + b) / 2 to first order in k h^2, as if the step
 * carried a damper k h. h + b is the same for every substep up to SIM_FTL_DAMPING_STEP (the
 * defaults' 1/240 s, whose b it keeps), so the springs damp the same per unit of time at any
 * shorter one (sim_limits.h). The DFTL solver's shape weights (sim_step_stiffness) and the PBD
 * solver's springs alike. Pure. */
float sim_step_shape_damping(float h);

/* The shape weights of level l of nv, from the stiffnesses k (1/s^2) faded linearly to
 * stiffness_tip at the tip: with w = k h^2 for the spring and c = k h b for its damper
 * (b = sim_step_shape_damping(h)), the spring's weight is w / (1 + w + c) and the damper's
 * c / (1 + w + c) (the implicit step of both). A vertex held against an acceleration g settles
 * g / k from its target whatever dt and substeps are, and the springs damp the same per unit of
 * time at any substep up to SIM_FTL_DAMPING_STEP (all 0 with shape off). Pure. */
void sim_step_stiffness(const sim_params *p, uint32_t l, uint32_t nv, sim_shape_weights *out);

/* One collider moved by head into world space. Pure. */
void sim_world_collider(const core_collider *in, core_xform head, sim_wcollider *out);

/* Checks what every backend needs of a groom (strands of >= 2 finite vertices, at most
 * SIM_MAX_COLLIDERS colliders, a size the backends can index, a distance grid of at most
 * SIM_SDF_MAX_SAMPLES finite samples). Pure. */
core_status sim_groom_check(const core_groom *g, core_err *err);

/* The contact floor of every vertex of g (nstrands x nverts floats in g's order): the signed
 * distance to the surface of g's distance grid that a collision push lifts the vertex to. The
 * groom is authored in contact with its character, so a vertex whose rest position lies inside
 * (or within the skin) may stay as deep as it is authored: min(SIM_SDF_SKIN, the grid's
 * distance at its rest position) for rest positions inside the grid's box, SIM_SDF_SKIN
 * elsewhere and without a grid. The PBD solver's pushes out of the grid (push_sdf in
 * sim_pbd_solve.c, the same in shaders/sim_pbd_substep.comp) take it as their target, so its
 * authored pose satisfies every contact. Pure; any thread. */
void sim_groom_contact_floor(const core_groom *g, float *out);

/* The longest rest segment of g (a collider-culling margin). Pure. */
float sim_groom_max_segment(const core_groom *g);

#endif
