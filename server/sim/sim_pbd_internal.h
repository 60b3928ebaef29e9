/* sim: the PBD solver's state, shared by its parts (private to sim_pbd*.c). */
#ifndef SIM_SIM_PBD_INTERNAL_H
#define SIM_SIM_PBD_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "sim.h"
#include "sim_pool.h"
#include "sim_step.h"

/* Strands solved side by side in one group (sim_pbd_solve.c group_view); divides SIM_CHUNK. */
#define SIM_PBD_LANES 8

/* Floats per vertex and lane of a worker's scratch for the group it solves (group_view). */
#define SIM_PBD_SCRATCH 41

/* Strand-major arrays in groom order: vertex v of strand s at 3 * (s * nv + v). */
typedef struct sim_pbd {
    uint32_t ns, nv;
    size_t n;                /* ns * nv */
    sim_params params;
    sim_pool pool;
    float *x, *v;            /* positions and velocities */
    float *start;            /* positions at the substep's start */
    float *rest;             /* rest positions in the head frame */
    float *len;              /* rest length of the segment ending at each vertex (0 for roots) */
    float *contact_floor;    /* per vertex: the distance from the grid's surface a push lifts it
                                to (sim_groom_contact_floor) */
    float *kg, *kl;          /* per level: global and local stiffness (1/s^2), faded to the tip */
    float *scratch;          /* per worker: SIM_PBD_SCRATCH x nv x SIM_PBD_LANES floats for its group */
    uint32_t ncolliders;
    core_collider colliders[CORE_MAX_COLLIDERS];
    core_sdf sdf;            /* copy of the groom's distance grid (sdf.d NULL = none) */
    core_xform head, prev_head;
    sim_step_desc step;      /* the step being taken (sim_step_plan) */
    uint64_t nan_per_worker[256];
    float stretch_per_worker[256]; /* per worker: the largest relative stretch the iterations left
                                      (sim_stats.pbd_stretch_max) since create or reset */
    uint64_t stretch_sum_per_worker[256]; /* per worker: the stretch sums in SIM_PBD_STRETCH_UNIT */
    uint64_t stretch_segments;            /* segments x substeps solved since create or reset */
    sim_stats stats;
} sim_pbd;

/* Substep k of p->step for every strand: Verlet prediction, pbd_iterations rounds of the
 * constraints (sim_pbd_solve.c), the closing root-to-tip distance pass, then velocities with
 * the DFTL correction and internal damping. Sim thread; uses the
 * pool. */
void sim_pbd_substep(sim_pbd *p, int k);

/* Puts strand s at its rest pose under head with zero velocity. */
void sim_pbd_restore_strand(sim_pbd *p, uint32_t s, core_xform head);

#endif
