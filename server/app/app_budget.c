/* app: the groom budget: one timed run per strand solver at start-up, then a check per groom. */
#include <stdlib.h>

#include "app_budget.h"
#include "groom/groom.h"

/* Particles a second sd's backend steps the standard groom with solver. */
static core_status measure_one(const sim_desc *sd, const core_groom *g, sim_solver solver, float *xyz, double *out,
                               core_err *err)
{
    sim_params p;
    sim_params_default(&p);
    p.solver = solver;
    sim s;
    core_status st = sim_create(&s, sd, g, &p, err);
    if (st != CORE_OK) return st;
    sim_timing t;
    st = sim_time_steps(&s, xyz, APP_BUDGET_STEPS, 0.0, &t, err);
    sim_destroy(&s);
    if (st == CORE_OK) *out = (double)APP_BUDGET_STRANDS * APP_BUDGET_VERTS / (t.best_s > 1e-9 ? t.best_s : 1e-9);
    return st;
}

core_status app_budget_measure(const sim_desc *sd, app_budget *b, core_err *err)
{
    core_groom g = { 0 };
    groom_desc gd = { .style = GROOM_STRAIGHT, .nstrands = APP_BUDGET_STRANDS, .nverts = APP_BUDGET_VERTS };
    core_status st = groom_procedural(&gd, &g, err);
    if (st != CORE_OK) return st;
    float *xyz = malloc((size_t)APP_BUDGET_STRANDS * APP_BUDGET_VERTS * 3 * sizeof *xyz);
    if (!xyz) st = core_fail(err, CORE_ENOMEM, "out of memory for the groom budget's measurement");
    if (st == CORE_OK) st = measure_one(sd, &g, SIM_SOLVER_DFTL, xyz, &b->dftl, err);
    if (st == CORE_OK) st = measure_one(sd, &g, SIM_SOLVER_PBD, xyz, &b->pbd, err);
    free(xyz);
    core_groom_free(&g);
    return st;
}

double app_budget_rate(const app_budget *b, sim_solver solver)
{
    return solver == SIM_SOLVER_PBD ? b->pbd : b->dftl;
}

core_status app_budget_check(double particles_per_s, double min_rate, sim_solver solver, uint32_t nstrands, uint32_t nverts,
                             core_err *err)
{
    double n = (double)nstrands * nverts, rate = particles_per_s / n;
    if (!(min_rate > 0.0) || !(particles_per_s > 0.0) || rate >= min_rate) return CORE_OK;
    return core_fail(err, CORE_EINVAL,
                     "%u x %u = %.0f particles would step at about %.1f steps/s with the %s solver on this machine, below "
                     "the %.0f steps/s the server keeps (it steps about %.0f particles at that rate); use fewer strands or "
                     "vertices",
                     nstrands, nverts, n, rate, sim_solver_name(solver), min_rate, particles_per_s / min_rate);
}
