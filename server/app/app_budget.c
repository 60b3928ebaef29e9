/* app: the groom budget: one timed run at start-up, then a check per groom. */
#include <stdlib.h>

#include "app_budget.h"
#include "groom/groom.h"

core_status app_budget_measure(const sim_desc *sd, double *particles_per_s, core_err *err)
{
    core_groom g = { 0 };
    groom_desc gd = { .style = GROOM_STRAIGHT, .nstrands = APP_BUDGET_STRANDS, .nverts = APP_BUDGET_VERTS };
    core_status st = groom_procedural(&gd, &g, err);
    if (st != CORE_OK) return st;
    sim_params p;
    sim_params_default(&p);
    sim s;
    st = sim_create(&s, sd, &g, &p, err);
    core_groom_free(&g);
    if (st != CORE_OK) return st;
    float *xyz = malloc((size_t)APP_BUDGET_STRANDS * APP_BUDGET_VERTS * 3 * sizeof *xyz);
    if (!xyz) {
        sim_destroy(&s);
        return core_fail(err, CORE_ENOMEM, "out of memory for the groom budget's measurement");
    }
    sim_timing t;
    st = sim_time_steps(&s, xyz, APP_BUDGET_STEPS, 0.0, &t, err);
    free(xyz);
    sim_destroy(&s);
    if (st != CORE_OK) return st;
    *particles_per_s = (double)APP_BUDGET_STRANDS * APP_BUDGET_VERTS / (t.best_s > 1e-9 ? t.best_s : 1e-9);
    return CORE_OK;
}

core_status app_budget_check(double particles_per_s, double min_rate, uint32_t nstrands, uint32_t nverts, core_err *err)
{
    double n = (double)nstrands * nverts, rate = particles_per_s / n;
    if (!(min_rate > 0.0) || rate >= min_rate) return CORE_OK;
    return core_fail(err, CORE_EINVAL,
                     "%u x %u = %.0f particles would step at about %.1f steps/s on this machine, below the %.0f steps/s "
                     "the server keeps (it steps about %.0f particles at that rate); use fewer strands or vertices",
                     nstrands, nverts, n, rate, min_rate, particles_per_s / min_rate);
}
