/* strandbench quality: runs one scenario (groom, parameters, motion preset) and measures it every frame. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bench_quality.h"
#include "support/quality.h"

const core_param_info *bq_param_find(const char *name)
{
    size_t n;
    const core_param_info *t = sim_param_table(&n);
    for (size_t i = 0; i < n; i++)
        if (strcmp(t[i].name, name) == 0) return &t[i];
    return NULL;
}

double bq_param_get(const sim_params *p, const core_param_info *t)
{
    const char *f = (const char *)p + t->offset;
    switch (t->type) {
    case CORE_PARAM_FLOAT: return *(const float *)f;
    case CORE_PARAM_INT:
    case CORE_PARAM_ENUM: return *(const int32_t *)f;
    case CORE_PARAM_BOOL: return *(const bool *)f ? 1.0 : 0.0;
    }
    return NAN;
}

void bq_param_set(sim_params *p, const core_param_info *t, double v)
{
    char *f = (char *)p + t->offset;
    switch (t->type) {
    case CORE_PARAM_FLOAT: *(float *)f = (float)v; break;
    case CORE_PARAM_INT:
    case CORE_PARAM_ENUM: *(int32_t *)f = (int32_t)lround(v); break;
    case CORE_PARAM_BOOL: *(bool *)f = v != 0.0; break;
    }
}

bool bq_params_equal(const sim_params *a, const sim_params *b)
{
    size_t n;
    const core_param_info *t = sim_param_table(&n);
    for (size_t i = 0; i < n; i++)
        if (bq_param_get(a, &t[i]) != bq_param_get(b, &t[i])) return false;
    return true;
}

/* The head transform after simulated time t: the preset, then an ease (smoothstep) from the
 * preset's last pose to the base pose over BQ_BLEND_S, then the base pose. */
static core_xform head_at(const bq_scenario *sc, double t)
{
    core_xform base = core_xform_identity();
    if (t <= sc->seconds_motion) return app_anim_head(sc->preset, t, base);
    double u = (t - sc->seconds_motion) / BQ_BLEND_S;
    if (u >= 1.0) return base;
    core_xform stop = app_anim_head(sc->preset, sc->seconds_motion, base);
    return core_xform_lerp(stop, base, (float)(u * u * (3.0 - 2.0 * u)));
}

/* The running maximum where a NaN wins and stays. */
static double worse(double worst, double x)
{
    if (isnan(worst) || isnan(x)) return NAN;
    return x > worst ? x : worst;
}

core_status bq_run(const bq_scenario *sc, bq_result *r, core_err *err)
{
    const core_groom *g = sc->groom;
    memset(r, 0, sizeof *r);
    r->nn_mean_m = NAN;
    const core_param_info *tdt = bq_param_find("dt");
    double dt = tdt ? bq_param_get(&sc->params, tdt) : 1.0 / 60.0;
    uint64_t nmotion = (uint64_t)llround(sc->seconds_motion / dt), nrest = (uint64_t)llround(sc->seconds_rest / dt);
    if (nrest < 1) nrest = 1;
    size_t nv = (size_t)g->nstrands * g->nverts;
    float *cur = malloc(3 * nv * sizeof *cur), *prev = malloc(3 * nv * sizeof *prev);
    double *scratch = malloc(nv * sizeof *scratch);
    if (!cur || !prev || !scratch) {
        free(cur);
        free(prev);
        free(scratch);
        return core_fail(err, CORE_ENOMEM, "quality: out of memory for %zu vertices", nv);
    }
    sim s;
    sim_desc d = { .backend = sc->backend, .threads = sc->threads };
    core_status st = sim_create(&s, &d, g, &sc->params, err);
    if (st == CORE_OK) st = sim_read_positions(&s, prev, err); /* the authored rest pose */
    double p999 = 0.0, step_s = 0.0;
    int64_t last_above = -1; /* the last rest frame at or above BQ_SETTLE_MM */
    for (uint64_t k = 0; st == CORE_OK && k < nmotion + nrest; k++) {
        core_xform h = head_at(sc, (double)(k + 1) * dt);
        sim_set_motion(&s, h);
        unsigned long long t0 = core_now_ns();
        st = sim_step(&s, err);
        if (st == CORE_OK) st = sim_read_positions(&s, cur, err);
        step_s += (double)(core_now_ns() - t0) * 1e-9;
        if (st != CORE_OK) break;
        p999 = quality_displacement_quantile(cur, prev, g->nstrands, g->nverts, BQ_QUANTILE, scratch);
        r->segment_error_max = worse(r->segment_error_max, quality_segment_error_max(g, cur, 1e-4));
        r->penetration_max_mm = worse(r->penetration_max_mm, 1e3 * quality_penetration_max(g, h, cur));
        if (k >= nmotion && !(p999 * 1e3 < BQ_SETTLE_MM)) last_above = (int64_t)(k - nmotion);
        float *t = prev;
        prev = cur;
        cur = t;
        r->steps++;
    }
    if (st == CORE_OK) {
        const float *x = prev; /* the last frame */
        r->rest_p999_mm = 1e3 * p999;
        r->settled = last_above < (int64_t)nrest - 1;
        r->settle_s = r->settled ? (double)(last_above + 1) * dt : sc->seconds_rest;
        r->shape_deviation = quality_shape_deviation(g, core_xform_identity(), x);
        r->tips_above_roots = quality_tips_above_roots(x, g->nstrands, g->nverts);
        r->steps_per_s = step_s > 0.0 ? (double)r->steps / step_s : 0.0;
        sim_stats ss;
        sim_get_stats(&s, &ss);
        r->nan_resets = ss.nan_resets;
        if (sc->want_nn) st = quality_nn_other_strand_mean(x, g->nstrands, g->nverts, &r->nn_mean_m, err);
    }
    sim_destroy(&s);
    free(cur);
    free(prev);
    free(scratch);
    return st;
}
