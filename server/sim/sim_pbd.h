/* sim: the PBD guide-strand solver (thesis 3.2) on the CPU: its backend table. */
#ifndef SIM_SIM_PBD_H
#define SIM_SIM_PBD_H

#include <stdint.h>

#include "sim.h"

/* The C backend of the PBD solver (static storage). Its instances follow the sim_vtable
 * contract: created from any thread, then used from one thread at a time (the sim thread). */
const sim_vtable *sim_pbd_vtable(void);

/* The global and local stiffness (1/s^2) of level l of nv: the table's values faded linearly to
 * stiffness_tip, 0 with shape off (as sim_step_stiffness does for the DFTL solver). Shared with
 * the Vulkan backend so that both have the same bits. Pure. */
void sim_pbd_stiffness(const sim_params *p, uint32_t l, uint32_t nv, float *kg, float *kl);

#endif
