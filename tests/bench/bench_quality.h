/* strandbench quality: one scenario's description and measured figures, and the parameter-table helpers. */
#ifndef BENCH_BENCH_QUALITY_H
#define BENCH_BENCH_QUALITY_H

#include <stdbool.h>
#include <stdint.h>

#include "app/app_anim.h"
#include "core/core.h"
#include "core/groom_types.h"
#include "sim/sim.h"

#define BQ_SETTLE_MM 0.01   /* still: the p99.9 per-frame displacement under this, mm */
#define BQ_BLEND_S 0.25     /* the head eases from the preset's last pose to the base pose */
#define BQ_QUANTILE 0.999   /* the displacement quantile reported */

/* One scenario: a groom, a full parameter set, a motion preset and how long to run. */
typedef struct bq_scenario {
    const core_groom *groom;    /* borrowed; its rest pose is the start and the reference */
    sim_params params;          /* complete (every table field set) */
    app_preset preset;
    double seconds_motion;      /* the preset plays this long (simulated s) */
    double seconds_rest;        /* then the head holds the base pose this long (the first
                                   BQ_BLEND_S of it easing there) */
    bool want_nn;               /* measure the mean nearest-other-strand distance at the end */
    sim_backend_kind backend;   /* CPU or VULKAN */
    int threads;                /* CPU worker threads, 0 = all cores */
} bq_scenario;

/* What one run measured; figures are NaN when they went non-finite. */
typedef struct bq_result {
    double rest_p999_mm;        /* p99.9 per-frame displacement of the last frame, mm */
    double settle_s;            /* from the end of the motion to the last frame above
                                   BQ_SETTLE_MM (seconds_rest when it never settles) */
    bool settled;               /* the last frame is below BQ_SETTLE_MM */
    double segment_error_max;   /* over every frame */
    double penetration_max_mm;  /* over every frame */
    double shape_deviation;     /* at the end, fraction of the mean strand length */
    double tips_above_roots;    /* at the end, fraction of strands */
    double nn_mean_m;           /* at the end (want_nn), else NaN */
    double steps_per_s;         /* sim_step calls only (metrics excluded) */
    uint64_t steps, nan_resets;
} bq_result;

/* Runs scenario sc from the groom's authored rest pose: the preset for seconds_motion, then
 * the head eases to the base pose (identity) over BQ_BLEND_S and holds it until seconds_rest
 * have passed since the motion ended, measuring every frame (tests/support/quality.h). The
 * step count follows the table's dt. Creates and destroys its own sim; CORE_* and err when the
 * sim cannot be created or a step fails. Single thread (the sim's workers aside). */
core_status bq_run(const bq_scenario *sc, bq_result *r, core_err *err);

/* The parameter table row named name, or NULL. */
const core_param_info *bq_param_find(const char *name);
/* The value of row t in p as a double (bools 0 or 1). */
double bq_param_get(const sim_params *p, const core_param_info *t);
/* Sets row t of p to v (rounded for ints, v != 0 for bools). */
void bq_param_set(sim_params *p, const core_param_info *t, double v);
/* True when every table field of a and b is equal. */
bool bq_params_equal(const sim_params *a, const sim_params *b);

#endif
