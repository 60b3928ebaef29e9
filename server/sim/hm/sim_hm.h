/* sim_hm: the hair-mesh solver (Yuksel et al. 2016) behind the sim_vtable. */
#ifndef SIM_HM_SIM_HM_H
#define SIM_HM_SIM_HM_H

#include <stdbool.h>
#include <stdint.h>

#include "../sim.h"

/* The backend table. create takes a groom whose hairmesh is set, with guides recorded
 * (nguides == nstrands; CORE_EINVAL otherwise); its own parameters are sim_params.hm;
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

#endif
