/* sim: the C reference backend (multi-threaded, deterministic for any thread count). */
#ifndef SIM_SIM_CPU_H
#define SIM_SIM_CPU_H

#include "sim.h"

/* The CPU backend's function table (static storage). */
const sim_vtable *sim_cpu_vtable(void);

#endif
