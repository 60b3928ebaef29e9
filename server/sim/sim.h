/* sim: the solver interface (parameters, backend function table) shared by all backends. */
#ifndef SIM_SIM_H
#define SIM_SIM_H

#include <stdbool.h>
#include <stdint.h>

#include "../core/core.h"
#include "../core/groom_types.h"
#include "../core/param.h"
#include "sim_limits.h"

/* The solvers (the `solver` parameter's choices, in this order). */
typedef enum sim_solver { SIM_SOLVER_DFTL = 0, SIM_SOLVER_HAIRMESH = 1, SIM_SOLVER_PBD = 2 } sim_solver;

/* The hair-mesh solver's own parameters (sim_params.hm; schema names hm_<field>). Stiffnesses
 * are per unit mass (every mesh vertex has unit mass) and per unit of time, so they mean the same
 * at any dt and substep count. */
typedef struct sim_hm_params {
    float stretch_stiffness; /* Baraff-Witkin stretch of the side and layer faces' triangles, 1/s^2 */
    float shear_stiffness;   /* Baraff-Witkin shear of the same triangles, 1/s^2 */
    float bend_stiffness;    /* Baraff-Witkin bend between side triangles sharing an edge, 1/s^2 */
    float volume_stiffness;  /* the corner tetrahedra's volume force, 1/s^2 (see hm/sim_hm_forces.c) */
    float damping;           /* the pair dampers' and the conditions' damping rate, 1/s */
    int32_t cg_iterations;   /* most modified-CG iterations per solve */
    float cg_tolerance;      /* CG stops when the preconditioned residual falls below this share of its start */
    bool deform_min;         /* deformation minimization after collisions (the paper's eq. 3-4) */
} sim_hm_params;

/* Physical and numerical parameters. Ranges and defaults are in sim_param_table();
 * sim_params_default() fills the defaults. Applied by a backend at a step boundary. */
typedef struct sim_params {
    int32_t solver;           /* sim_solver */
    float dt;                 /* seconds per step (one frame) */
    int32_t substeps;         /* solver substeps per step */
    float gravity;            /* m/s^2 along -y (world) */
    float wind_x, wind_y, wind_z; /* wind acceleration, m/s^2 (world) */
    float damping;            /* internal damping: velocity relative to the parent vertex decays at this rate, 1/s */
    float air_drag;           /* every vertex's velocity decays at this rate, 1/s */
    float dftl_correction;    /* s_d: DFTL velocity correction (eq. 14), [0,1] */
    float global_stiffness;   /* pull toward the rest pose in the root frame, 1/s^2 */
    float local_stiffness;    /* pull toward the rest shape in the parent's frame, 1/s^2 */
    float stiffness_tip;      /* both stiffnesses at the tip as a fraction of their root value */
    float repulsion;          /* SPH pressure coefficient k */
    float viscosity;          /* SPH viscosity (friction between strands), 1/s */
    float sph_radius;         /* SPH smoothing length h, m */
    float rest_density;       /* SPH rest density as a multiple of the groom's rest-pose mean */
    int32_t neighbor_cap;     /* SPH neighbours kept per particle (nearest first), <= SIM_MAX_NEIGHBOR_CAP */
    bool shape;               /* global + local shape constraints on */
    bool sph;                 /* hair-hair interaction on */
    bool collisions;          /* character colliders on */
    float friction;           /* contact friction, [0,1]: a vertex in contact keeps still while its
                                 tangential displacement over a substep is at most friction times
                                 the push out; past that it is reduced by that much (Coulomb) */
    float hair_friction;      /* hair-hair static friction, dimensionless: a vertex's motion relative
                                 to its SPH neighbours is held by an accumulated acceleration of at
                                 most this times its pressure's push (sim_cpu_sph.c hold_accel) */
    int32_t pbd_iterations;   /* PBD: constraint iterations per substep */
    sim_hm_params hm;         /* the hair-mesh solver's own (gravity, wind, air drag, dt, substeps,
                                 collisions and friction above apply to it too) */
} sim_params;

/* Fills p with the defaults of sim_param_table(). Pure. */
void sim_params_default(sim_params *p);

/* The parameter table (static storage, never freed); *count receives its length. */
const core_param_info *sim_param_table(size_t *count);

/* Checks every field against the table (type, finite, range). Returns CORE_EINVAL naming the
 * first bad field and why. Pure. */
core_status sim_params_validate(const sim_params *p, core_err *err);

/* The name of solver (the `solver` parameter's choice), "unknown" out of range. Pure. */
const char *sim_solver_name(int32_t solver);

/* Checks that p->solver can run on groom g: hairmesh needs a hair-mesh groom. Returns
 * CORE_EINVAL with a message naming the solver otherwise. Pure. */
core_status sim_solver_check(const sim_params *p, const core_groom *g, core_err *err);

/* Feature bits used by benchmarks and logs. */
typedef enum sim_features {
    SIM_FEAT_DFTL = 0,               /* inextensibility only */
    SIM_FEAT_SHAPE = 1,              /* + shape constraints */
    SIM_FEAT_SPH = 2                 /* + hair-hair interaction */
} sim_features;

typedef enum sim_backend_kind { SIM_BACKEND_AUTO = 0, SIM_BACKEND_CPU, SIM_BACKEND_VULKAN } sim_backend_kind;

/* Creation options; zero means default. */
typedef struct sim_desc {
    sim_backend_kind backend; /* AUTO: see sim_create */
    int threads;              /* CPU worker threads; 0 = number of online cores */
    int device;               /* Vulkan device: 0 = automatic (discrete, integrated, virtual, then
                                 CPU); N >= 1 = physical device N-1 (vulkaninfo's GPU<N-1>) */
    bool portable;            /* CPU backend: portable scalar kernels only, no AVX2 intrinsics
                                 (the two give the same bits; tests compare them) */
} sim_desc;

/* Counters a backend keeps; read with sim_get_stats. */
typedef struct sim_stats {
    uint64_t steps;           /* steps taken since create or reset */
    double sim_time;          /* seconds simulated since create or reset */
    uint64_t nan_resets;      /* strands restored to rest after a non-finite value */
    double last_step_ms;      /* wall time of the last step */
    /* optional per-stage breakdown of the last step in ms (0 when not measured) */
    double stage_ms[8];
    const char *stage_names[8];
    int nstages;
    uint64_t device_bytes;    /* bytes of the GPU buffers the backend holds (0 on the CPU backends) */
    double pbd_stretch_max;   /* PBD: the largest relative segment-length error |(|x_l - x_l-1|) -
                                 len| / len the pbd_iterations left to the closing root-to-tip pass,
                                 over every substep since create or reset (0 on the other solvers) */
    double pbd_stretch_mean;  /* PBD: its mean over every segment and substep since create or reset
                                 (each strand's sum over a substep capped at SIM_PBD_STRETCH_CAP) */
    uint64_t sph_passes;      /* CPU backend: SPH evaluations of this solver since create or reset */
    uint64_t sph_searches;    /* CPU backend: those among them that searched the neighbours anew
                                 (the others kept the lists of the last search, see sim_cpu_sph.c) */
} sim_stats;

/* Asked by a backend between the stages of a step (sim_set_cancel): true abandons the step. */
typedef bool (*sim_cancel_fn)(void *ctx);

typedef struct sim_vtable {
    const char *name;
    core_status (*create)(const sim_desc *desc, const core_groom *groom, const sim_params *params,
                          void **out, core_err *err);
    core_status (*set_params)(void *self, const sim_params *params, core_err *err);
    void (*set_motion)(void *self, core_xform head);
    core_status (*step)(void *self, core_err *err);
    core_status (*read_positions)(void *self, float *xyz, core_err *err);
    core_status (*write_state)(void *self, const float *xyz, const float *vel, core_err *err);
    core_status (*read_state)(void *self, float *xyz, float *vel, core_err *err);
    void (*reset)(void *self);
    void (*get_stats)(void *self, sim_stats *out);
    void (*destroy)(void *self);
    void (*set_cancel)(void *self, sim_cancel_fn poll, void *ctx); /* NULL: steps cannot be abandoned */
    /* optional (NULL for strand solvers): the hair mesh's vertices, xyz = 3 * ncols * nlayers
     * floats, column-major as core_hairmesh.pos, world frame */
    core_status (*read_hairmesh)(void *self, float *xyz, core_err *err);
} sim_vtable;

/* A solver instance: a backend table plus its state, the options it was created with and the
 * last head transform it was given (a solver switch carries it over). */
typedef struct sim {
    const sim_vtable *vt;
    void *self;
    uint32_t nstrands, nverts;
    sim_desc desc;
    int32_t solver;
    core_xform head;
    /* steps, sim_time and nan_resets of the solvers switched away from since the last reset
     * (sim_get_stats adds them, so the counters go on across a switch) */
    uint64_t prior_steps, prior_nan_resets;
    double prior_time;
    sim_cancel_fn cancel;    /* the poll of sim_set_cancel (a switch hands it to the new solver) */
    void *cancel_ctx;
} sim;

/* Creates solver params->solver for groom (copied; the caller keeps ownership of groom) with
 * params (validated; sim_solver_check). dftl and pbd run on both backends; hairmesh has no
 * Vulkan backend and runs on the CPU backend whatever desc->backend asks, saying so in the log.
 * backend AUTO (for a solver with a Vulkan backend) uses a hardware Vulkan device when present;
 * with only a CPU Vulkan device (lavapipe) it times a few steps of each backend on this groom and keeps the faster;
 * if Vulkan set-up fails it falls back to the CPU backend and logs why. On failure *s is zeroed
 * and err says why. Any thread may create a sim; it is then used from one thread at a time (the
 * sim thread). */
core_status sim_create(sim *s, const sim_desc *desc, const core_groom *groom, const sim_params *params,
                       core_err *err);

/* Validates and applies params from the next step on; params->solver must be the running one
 * (sim_change switches). Sim thread. */
core_status sim_set_params(sim *s, const sim_params *params, core_err *err);

/* Validates and applies params like sim_set_params; when params->solver differs from the running
 * solver it creates that solver for groom (the one s was created with; borrowed) with the
 * options s was created with (so on the same backend where the solver has it), carries the positions, velocities and
 * head transform over and destroys the old one. On failure s is unchanged and err says why.
 * Sim thread. */
core_status sim_change(sim *s, const core_groom *groom, const sim_params *params, core_err *err);

/* Sets the head transform reached at the end of the next step; roots and colliders are
 * interpolated from the previous one across its substeps. Sim thread. */
void sim_set_motion(sim *s, core_xform head);

/* Advances one step of params.dt. Sim thread. */
core_status sim_step(sim *s, core_err *err);

/* Lets the step in progress be abandoned: between its stages (after the SPH pass, after each
 * substep but the last) the backend calls poll(ctx) on the sim thread, and when it returns true
 * it puts back the state it had before the step, bit for bit as far as any later step can tell,
 * and sim_step returns CORE_ECANCELED (err says so) without counting a step. The caller then
 * applies whatever made it ask (a parameter change) and steps again, so a change waits for its
 * own step only, not also for the rest of the one in progress. The backend keeps a copy of the
 * positions and velocities while poll is set (a few MB per step); poll NULL turns this off
 * (the default). Returns false for a backend that cannot abandon a step (Vulkan: its step is
 * one submission; the PBD solver): its steps run to the end. s keeps poll across sim_change:
 * the solver switched to gets it. Sim thread. */
bool sim_set_cancel(sim *s, sim_cancel_fn poll, void *ctx);

/* Copies positions out, strand-major xyz (3 * nstrands * nverts floats, caller-owned). */
core_status sim_read_positions(sim *s, float *xyz, core_err *err);

/* Copies the hair mesh's vertices out (3 * ncols * nlayers floats, column-major as
 * core_hairmesh.pos, world frame, caller-owned) from a solver that simulates one; a strand
 * solver answers CORE_EUNSUPPORTED. Sim thread. */
core_status sim_read_hairmesh(sim *s, float *xyz, core_err *err);

/* What sim_time_steps measured. */
typedef struct sim_timing {
    int steps;        /* timed steps */
    double mean_s;    /* seconds per step over them */
    double best_s;    /* the fastest one */
} sim_timing;

/* Times up to `steps` steps of s after one untimed warm-up step (first-touch pages, the rest
 * density), each followed by sim_read_positions into xyz (caller-owned, 3 * nstrands * nverts
 * floats) so queued GPU work is counted; it stops early once budget_s seconds have passed
 * (budget_s <= 0: no limit). The solver's state moves on (sim_reset it afterwards if that
 * matters). Used by the AUTO backend trial and the groom budget. Sim thread of s. (sim_time.c) */
core_status sim_time_steps(sim *s, float *xyz, int steps, double budget_s, sim_timing *out, core_err *err);

/* Reads or replaces the full state (positions and velocities, strand-major xyz). A replaced
 * state keeps the positions of the last SPH evaluation: the next evaluation's viscosity takes
 * the change of position as motion (none on a solver that has not evaluated SPH yet). */
core_status sim_read_state(sim *s, float *xyz, float *vel, core_err *err);
core_status sim_write_state(sim *s, const float *xyz, const float *vel, core_err *err);

/* Puts every strand back to its rest pose under the current head transform, zero velocity. */
void sim_reset(sim *s);

void sim_get_stats(sim *s, sim_stats *out);

/* The backend s runs on (CPU or VULKAN, never AUTO): what to ask for to get the same again
 * without sim_create's AUTO trial. Any thread. */
sim_backend_kind sim_backend(const sim *s);

/* Frees everything; safe on a zeroed sim. */
void sim_destroy(sim *s);

#endif
