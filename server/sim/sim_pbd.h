/* sim: the PBD guide-strand solver (thesis 3.2) on the CPU: its backend table. */
#ifndef SIM_SIM_PBD_H
#define SIM_SIM_PBD_H

#include "sim.h"

/* The C backend of the PBD solver (static storage). Its instances follow the sim_vtable
 * contract: created from any thread, then used from one thread at a time (the sim thread). */
const sim_vtable *sim_pbd_vtable(void);

#endif
