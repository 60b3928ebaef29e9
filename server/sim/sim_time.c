/* sim: times a few steps of a solver (the AUTO backend trial and the groom budget). */
#include "sim.h"

core_status sim_time_steps(sim *s, float *xyz, int steps, double budget_s, sim_timing *out, core_err *err)
{
    *out = (sim_timing){ 0 };
    core_status st = sim_step(s, err);
    if (st == CORE_OK) st = sim_read_positions(s, xyz, err);
    unsigned long long t0 = core_now_ns();
    double best = 0.0;
    int done = 0;
    while (st == CORE_OK && done < steps) {
        unsigned long long t1 = core_now_ns();
        st = sim_step(s, err);
        if (st == CORE_OK) st = sim_read_positions(s, xyz, err);
        double secs = (double)(core_now_ns() - t1) * 1e-9;
        best = done == 0 || secs < best ? secs : best;
        done++;
        if (budget_s > 0.0 && (double)(core_now_ns() - t0) * 1e-9 > budget_s) break;
    }
    if (st != CORE_OK) return st;
    out->steps = done;
    out->mean_s = done ? (double)(core_now_ns() - t0) * 1e-9 / done : 0.0;
    out->best_s = best;
    return CORE_OK;
}
