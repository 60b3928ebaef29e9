/* sim: the CPU backend's state, shared by its step stages (private to sim_cpu*.c). */
#ifndef SIM_SIM_CPU_INTERNAL_H
#define SIM_SIM_CPU_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "sim.h"
#include "sim_pool.h"
#include "sim_step.h"

/* Scratch of the SPH stage (grid, sorted copies, neighbour lists); grown on demand. */
typedef struct sim_cpu_sph {
    size_t n;                /* particles the per-particle arrays hold */
    size_t cells_cap;        /* cells the per-cell arrays hold */
    int cap;                 /* neighbour slots per particle the arrays hold */
    bool lists_valid;        /* order/nbr describe the particles as of the last build, at
                                build_head (kept while no particle strays, see sim_cpu_sph.c) */
    bool portable;           /* use the portable scalar kernels even where AVX2 ones exist */
    core_xform build_head;   /* the head the particles moved with when the lists were built */
    uint32_t *cell;          /* hash bucket of each particle, original order */
    uint32_t *order;         /* sorted slot -> original particle index */
    uint32_t *slot_of;       /* original particle index -> sorted slot (order's inverse) */
    uint32_t *strand;        /* sorted slot -> strand index */
    float *sp, *sv;          /* sorted (x, y, z, density) and (vx, vy, vz, pressure) */
    float *sx, *sy, *sz;     /* sorted positions as SoA at the last build (the scan's input) */
    uint32_t *nbr;           /* per sorted slot: neighbour_cap sorted slots, the nearest within
                                the skin radius at the last build (those beyond h add nothing) */
    uint8_t *nnbr;           /* per sorted slot: entries of its nbr row */
    uint32_t *cell_start;    /* buckets + 1: first sorted slot of each bucket */
    float *dbox;             /* per grid cell of an unfolded grid (its bucket), SPH_BOX floats: the
                                low and high corners of its particles' offsets from their carried
                                build positions and the largest squared one (sim_cpu_sph.c) */
    uint32_t *hist;          /* nthreads x cells: counts, then scatter cursors */
    size_t tsum[257];        /* per-thread partial sums of the prefix scan */
    size_t tocc[257];        /* per-thread counts of occupied buckets in the prefix scan */
    size_t occupied;         /* buckets holding particles at the last search */
    uint64_t pass_no;        /* SPH passes completed (not the rest pass) */
    uint64_t search_pass;    /* pass_no at the last search */
    uint64_t beyond_pass;    /* pass_no at which an offset first passed half the skin since the last
                                search (UINT64_MAX: none has; see lists_hold) */
    /* grid of the current pass: cells of cell_size from origin, hashed into ncells buckets */
    float origin[3], cell_size, inv_cell;
    uint32_t dims[3];
    size_t ncells;
    size_t dbox_cap;         /* grid cells dbox holds */
} sim_cpu_sph;

/* The cells of the last build's SPH grid: dims[0] x dims[1] x dims[2]. */
static inline size_t sim_cpu_sph_grid_cells(const sim_cpu_sph *s)
{
    return (size_t)s->dims[0] * s->dims[1] * s->dims[2];
}

/* True when the last build's grid has no more cells than buckets: bucket = the cell's linear
 * index, so a cell's neighbours are found by offsets (the kept lists' relative check, see
 * sim_cpu_sph.c). */
static inline bool sim_cpu_sph_unfolded(const sim_cpu_sph *s) { return sim_cpu_sph_grid_cells(s) <= s->ncells; }

typedef struct sim_cpu {
    uint32_t ns, nv;
    size_t n;                /* ns * nv */
    sim_params params;
    sim_pool pool;
    /* level-major SoA: index = level * ns + strand */
    float *x[3], *v[3], *a[3], *rest[3];
    float *xe[3];            /* positions at the last SPH evaluation (the viscosity's motion) */
    float *af;               /* the hair-hair friction's held acceleration (included in a): x, y, z
                                and 0 at 4 index, so the force pass's scattered access to a
                                particle's is one cache line */
    sim_shape_weights *sw;   /* per-level shape weights (sim_step_stiffness) */
    float max_segment;       /* longest rest segment */
    uint32_t *perm;          /* internal strand -> groom strand (roots in Morton order, so
                                neighbouring strands are near each other) */
    uint32_t ncolliders;
    core_collider colliders[CORE_MAX_COLLIDERS];
    core_sdf sdf;            /* copy of the groom's distance grid (sdf.d NULL = none) */
    core_xform head, prev_head;
    sim_step_desc step;      /* the step being taken (sim_step_plan) */
    sim_cpu_sph sph;
    float rho_rest;          /* mean rest-pose SPH density (for the current h, cap) */
    bool rho_rest_valid;
    sim_sph_clock sph_clock; /* whether a holds an SPH acceleration (its low-pass state), and its age */
    float sph_auto_h;        /* the groom's automatic smoothing length (sim_sph_auto_radius) */
    uint64_t nan_per_thread[256];
    sim_stats stats;
    /* sim_set_cancel: the poll, and the state before the step in progress to go back to */
    sim_cancel_fn cancel;
    void *cancel_ctx;
    float *saved_x[3], *saved_v[3], *saved_a[3], *saved_xe[3], *saved_af; /* allocated on the first cancellable step */
    sim_sph_clock saved_clock;
    uint64_t saved_nan[256];
} sim_cpu;

/* Computes SPH accelerations into c->a from positions pos (c->x) and, for the viscosity, their
 * motion (pos - prev) * inv_since since the last evaluation (prev: c->xe; pos may be c->rest
 * for the rest-density pass, with prev NULL and out_mean_rho set). The particles move with head `frame`
 * (the head the positions were last placed under). The neighbours are those within h now,
 * whether the skin lists of the previous pass are kept or rebuilt. With cancellable, c->cancel
 * is polled after the lists and after the densities: CORE_ECANCELED when it says so, c->a not
 * yet written and the lists complete (built from `pos`, so a pass taken again from the same
 * positions keeps them and gives the same bits). Sim thread; uses the pool. */
core_status sim_cpu_sph_pass(sim_cpu *c, float *const pos[3], float *const prev[3], float inv_since, float dt,
                             core_xform frame, double *out_mean_rho, bool cancellable, core_err *err);
void sim_cpu_sph_free(sim_cpu_sph *s);

/* Substep k of c->step: predict + DFTL/shape/collision chain + velocity update. Sim thread;
 * uses the pool. */
void sim_cpu_chain_pass(sim_cpu *c, int k);

#endif
