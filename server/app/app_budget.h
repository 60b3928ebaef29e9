/* app: the groom budget: grooms this machine's backend cannot step at a minimum rate with the
 * active solver are refused (too_large, with the numbers) instead of taking the service down.
 * The rates are measured once at start-up on a standard groom, one per strand solver. Pure
 * apart from the measurement; any thread. */
#ifndef APP_BUDGET_H
#define APP_BUDGET_H

#include <stdint.h>

#include "core/core.h"
#include "sim/sim.h"

#define APP_MIN_STEP_RATE 10.0  /* steps/s a groom must reach (app_desc.min_step_rate 0) */
#define APP_BUDGET_STRANDS 2048u /* the measuring groom: procedural straight, 2048 x 32 */
#define APP_BUDGET_VERTS 32u
#define APP_BUDGET_STEPS 3       /* timed steps (the fastest counts), after one warm-up step */

/* Particles a second each strand solver steps on this machine (0 = no budget). */
typedef struct app_budget {
    double dftl, pbd;
} app_budget;

/* Particles a second the backend of sd steps with the DFTL and the PBD solver at the default
 * parameters (every feature on), each measured on the standard groom (tens of milliseconds on
 * the CPU backend): from the fastest of APP_BUDGET_STEPS steps, so a busy moment of a shared
 * machine does not shrink the budget. */
core_status app_budget_measure(const sim_desc *sd, app_budget *b, core_err *err);
/* The rate that bounds a groom under solver: the hair-mesh solver's strands are traced from the
 * simulated mesh, cheaper than DFTL's, whose rate bounds them. */
double app_budget_rate(const app_budget *b, sim_solver solver);
/* CORE_EINVAL, with the counts, the solver's name and rates in err, when a groom of
 * nstrands x nverts would step slower than min_rate at particles_per_s. */
core_status app_budget_check(double particles_per_s, double min_rate, sim_solver solver, uint32_t nstrands, uint32_t nverts,
                             core_err *err);

#endif
