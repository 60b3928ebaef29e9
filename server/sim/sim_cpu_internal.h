/* sim: the CPU backend's state, shared by its step stages (private to sim_cpu*.c). */
#ifndef SIM_SIM_CPU_INTERNAL_H
#define SIM_SIM_CPU_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "sim.h"
#include "sim_pool.h"

/* A collider transformed to world space for one substep. */
typedef struct sim_cpu_wcollider {
    core_collider_kind kind;
    core_vec3 a, b;      /* world centre / segment ends */
    float radius;
    core_vec3 radii;
    core_quat rot;       /* world orientation (ellipsoid) */
    float lo[3], hi[3];  /* world bounding box, for culling */
    float axis[3];       /* capsule: b - a (zero for a sphere, which is a capsule of length 0) */
    float inv_axis2;     /* 1 / |axis|^2, 0 for a sphere */
    float to_unit[9];    /* ellipsoid: world offset -> unit-sphere coords (diag(1/r) R^T), row-major */
    float from_unit[9];  /* ellipsoid: unit-sphere coords -> world offset (R diag(r)), row-major */
} sim_cpu_wcollider;

/* Scratch of the SPH stage (grid, sorted copies, neighbour lists); grown on demand. */
typedef struct sim_cpu_sph {
    size_t n;                /* particles the per-particle arrays hold */
    size_t cells_cap;        /* cells the per-cell arrays hold */
    int cap;                 /* neighbour slots per particle the arrays hold */
    bool lists_valid;        /* order/nbr describe the current particles (may be reused) */
    bool scalar;             /* use the scalar kernels even where AVX2 ones exist */
    uint32_t *cell;          /* hash bucket of each particle, original order */
    uint32_t *order;         /* sorted slot -> original particle index */
    uint32_t *strand;        /* sorted slot -> strand index */
    float *sp, *sv;          /* sorted (x, y, z, density) and (vx, vy, vz, pressure) */
    float *sx, *sy, *sz;     /* sorted positions again as SoA, for the vectorized scan */
    uint32_t *nbr;           /* per sorted slot: neighbour_cap sorted slots */
    uint8_t *nnbr;           /* per sorted slot: neighbours kept */
    uint32_t *cell_start;    /* buckets + 1: first sorted slot of each bucket */
    uint32_t *hist;          /* nthreads x cells: counts, then scatter cursors */
    size_t tsum[257];        /* per-thread partial sums of the prefix scan */
    /* grid of the current pass: cells of cell_size from origin, hashed into ncells buckets */
    float origin[3], cell_size, inv_cell;
    uint32_t dims[3];
    size_t ncells;
} sim_cpu_sph;

typedef struct sim_cpu {
    uint32_t ns, nv;
    size_t n;                /* ns * nv */
    sim_params params;
    sim_pool pool;
    /* level-major SoA: index = level * ns + strand */
    float *x[3], *v[3], *a[3], *rest[3];
    float *sg, *sl;          /* per-level shape stiffness */
    float max_segment;       /* longest rest segment */
    uint32_t *perm;          /* internal strand -> groom strand (roots in Morton order, so
                                neighbouring strands are near each other) */
    uint32_t ncolliders;
    core_collider colliders[CORE_MAX_COLLIDERS];
    core_xform head, prev_head;
    sim_cpu_sph sph;
    float rho_rest;          /* mean rest-pose SPH density (for the current h, cap) */
    bool rho_rest_valid;
    uint64_t nan_per_thread[256];
    sim_stats stats;
} sim_cpu;

/* Computes SPH accelerations into c->a from c->x, c->v (positions `pos` may be c->rest for the
 * rest-density pass, with vel NULL and out_mean_rho set). Unless rebuild, the neighbour lists
 * of the previous pass are reused (distances recomputed). Sim thread; uses the pool. */
core_status sim_cpu_sph_pass(sim_cpu *c, float *const pos[3], float *const vel[3], float dt, bool rebuild,
                             double *out_mean_rho, core_err *err);
void sim_cpu_sph_free(sim_cpu_sph *s);

/* One substep of predict + DFTL/shape/collision chain + velocity update, with the head at
 * `head` (interpolated) and step length dt. Sim thread; uses the pool. */
void sim_cpu_chain_pass(sim_cpu *c, core_xform head, float dt, bool use_sph_accel);

/* Transforms the head-frame colliders by head into out (count = c->ncolliders). Pure. */
void sim_cpu_world_colliders(const sim_cpu *c, core_xform head, sim_cpu_wcollider *out);

#endif
