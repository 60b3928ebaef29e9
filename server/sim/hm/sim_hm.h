/* sim_hm: the hair-mesh solver (Yuksel et al. 2016) behind the sim_vtable, and its own parameters. */
#ifndef SIM_HM_SIM_HM_H
#define SIM_HM_SIM_HM_H

#include <stdbool.h>
#include <stdint.h>

#include "../sim.h"

/* The hair-mesh solver's own parameters (gravity, wind, air drag, dt, substeps, collisions and
 * friction come from sim_params). Stiffnesses are per unit mass (every mesh vertex has unit
 * mass) and per unit of time, so they mean the same at any dt and substep count. Ranges and
 * defaults are in sim_hm_param_table(). */
typedef struct sim_hm_params {
    float stretch_stiffness; /* springs along the columns and the layers' edges, 1/s^2 */
    float shear_stiffness;   /* springs along the diagonals of the prisms' sides and quads, 1/s^2 */
    float bend_stiffness;    /* springs between layers l and l + 2 of a column, 1/s^2 */
    float volume_stiffness;  /* the corner tetrahedra's volume force, 1/s^2 (see sim_hm_forces.c) */
    float damping;           /* each spring's damper: relative velocity along it decays at this rate, 1/s */
    int32_t cg_iterations;   /* most modified-CG iterations per solve */
    float cg_tolerance;      /* CG stops when the preconditioned residual falls below this share of its start */
    bool deform_min;         /* deformation minimization after collisions (the paper's eq. 3-4) */
} sim_hm_params;

/* The parameter table (static storage); *count receives its length. */
const core_param_info *sim_hm_param_table(size_t *count);

/* Fills p with the table's defaults. Pure. */
void sim_hm_params_default(sim_hm_params *p);

/* Checks every field against the table (finite, range); CORE_EINVAL naming the first bad one. Pure. */
core_status sim_hm_params_validate(const sim_hm_params *p, core_err *err);

/* The backend table. create takes a groom whose hairmesh is set, with guides recorded
 * (nguides == nstrands; CORE_EINVAL otherwise) and starts from sim_hm_params_default;
 * read_positions traces the guide strands through the current mesh (3 * nstrands * nverts
 * floats, strand-major, world frame); read_state / write_state / read_hairmesh work on the mesh
 * vertices (3 * ncols * nlayers floats each, column-major as core_hairmesh.pos, world frame);
 * reset puts the mesh back to its rest shape under the current head; get_stats fills the stage
 * times of the last step (forces, cg, collisions, deform_min); set_cancel is NULL (a step cannot
 * be abandoned). One thread at a time. */
extern const sim_vtable sim_hm_vtable;

/* Fills s with a hair-mesh solver for groom (copied) and params (validated), as sim_create does
 * for the strand solvers. On failure *s is zeroed and err says why. Any thread. */
core_status sim_hm_open(sim *s, const sim_desc *desc, const core_groom *groom, const sim_params *params,
                        core_err *err);

/* Validates and applies p from the next step on to s, which must be a hair-mesh solver
 * (CORE_EUNSUPPORTED otherwise). Sim thread. */
core_status sim_hm_set_params(sim *s, const sim_hm_params *p, core_err *err);

#endif
