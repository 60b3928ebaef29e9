/* strandbench quality: how the hair behaves (stillness, settling, stretch, penetration, shape, volume) per groom x parameter value x motion. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "bench_quality.h"
#include "core/cli.h"
#include "groom/groom.h"
#include "support/quality.h"

#define BQ_DEFAULT_STRANDS 512u
#define BQ_DEFAULT_VERTS 16u
#define BQ_DEFAULT_GROOM_FILE "../shared/assets/ratboy/Ratboy_mohawk.tfx"
#define BQ_MAX_GROOMS 4

/* The parameters that act on hair-hair interaction: their scenarios also measure nn_gain
 * (the table's "sph" row switched off for the comparison run). */
static const char *const sph_param_names[] = { "sph", "repulsion", "viscosity", "sph_radius",
                                               "rest_density", "neighbor_cap" };

static bool is_sph_param(const char *name)
{
    for (size_t i = 0; i < sizeof sph_param_names / sizeof sph_param_names[0]; i++)
        if (strcmp(name, sph_param_names[i]) == 0) return true;
    return false;
}

static void usage(void)
{
    printf("usage: strandbench quality [--backend cpu|vulkan] [--groom straight|wavy|curly|ratboy]\n"
           "                           [--param NAME] [--preset NAME] [--strands N] [--verts N]\n"
           "                           [--groom-file PATH] [--seconds-motion S] [--seconds-rest S]\n"
           "                           [--threads N] [--full] [--nn] [--json]\n"
           "Runs the solver the way a technical artist looks at it and measures what they judge.\n"
           "A scenario is one groom, one parameter of the solver's table set to one value (the others\n"
           "at their defaults) and one head-motion preset. The default grid, per groom: the baselines\n"
           "(param \"defaults\": every parameter at its default, under each preset), then every table\n"
           "parameter at its min and max (bools: the value that is not the default), one preset per\n"
           "scenario cycling none, nod, shake, circle, headbang, sway. With --param NAME or --full the\n"
           "parameters run at min, default and max (bools 0 and 1) and there are no baselines.\n"
           "A parameter of one solver only (pbd_iterations) runs under that solver (the row's\n"
           "\"solver\"); the hair-mesh solver's (hm_*) need a hair-mesh groom and are left out\n"
           "(strandbench hairmesh measures that solver).\n"
           "Each scenario starts from the authored rest pose\n"
           "(what a user sees first), plays the preset for --seconds-motion, then the head eases back\n"
           "to the base pose over %.2f s (smoothstep, so the stop is no jump) and holds it; the rest\n"
           "period lasts --seconds-rest from the end of the motion (the ease included). Every frame\n"
           "is one step of the table's dt, so the step count follows dt.\n"
           "Options:\n"
           "  --backend cpu|vulkan  solver backend (default cpu)\n"
           "  --groom NAME          only this groom: straight, wavy, curly (procedural) or ratboy (file)\n"
           "  --param NAME          only this parameter of the table (every value of it)\n"
           "  --preset NAME         this motion preset for every scenario instead of the cycle\n"
           "  --strands N           procedural strands (default %u for speed; the daemon's default\n"
           "                        groom is 4096x32)\n"
           "  --verts N             vertices per strand of every groom, the file groom resampled to it\n"
           "                        (default %u for speed; Ratboy's file has 32)\n"
           "  --groom-file PATH     the ratboy groom (default %s;\n"
           "                        skipped with a note when absent)\n"
           "  --collider-file PATH  the ratboy groom's collision mesh (.obj/.tfxmesh), its distance grid\n"
           "                        built over what the hair can reach, as strandcastd --collider does\n"
           "                        (2 mm cells, coarser past 8.4 M samples); none by default\n"
           "  --seconds-motion S    preset duration, simulated seconds (default 2)\n"
           "  --seconds-rest S      rest period after the motion, simulated seconds (default 3)\n"
           "  --threads N           CPU solver threads (default: all cores)\n"
           "  --full                every parameter at min, default and max instead of baselines + min, max\n"
           "  --nn                  measure nn_gain for every scenario, not only baselines and SPH parameters\n"
           "  --json                one JSON object per line per scenario, then one per groom summary\n"
           "Metrics (\"non-root\": roots follow the head and are not judged):\n"
           "  rest_p999_mm        p99.9 over non-root vertices of the per-frame displacement |x(t)-x(t-dt)|\n"
           "                      on the last frame, mm: jitter or creep at rest (0 = perfectly still)\n"
           "  settle_s            seconds from the end of the motion to the last frame whose p99.9\n"
           "                      displacement is >= %.2f mm (it stays below afterwards); when the last\n"
           "                      frame is above, it never settled: seconds-rest, \"settled\": false, '>'\n"
           "  segment_error_max   max over frames and segments of |len / rest_len - 1| (stretch)\n"
           "  penetration_max_mm  max over frames of how deep a non-root vertex is inside a collider of\n"
           "                      the groom (sphere, capsule, ellipsoid along its radial direction) or\n"
           "                      its mesh's distance grid, mm; for the mesh, beyond the depth the\n"
           "                      vertex is authored at (the groom touches the body: a vertex authored\n"
           "                      d inside may stay d deep)\n"
           "  shape_deviation     at the end: mean over non-root vertices of |x - authored position|\n"
           "                      (head at the base pose) / the groom's mean strand length\n"
           "  tips_above_roots    at the end: fraction of strands whose tip is higher (y) than its root;\n"
           "                      tips_above_roots_authored: the same on the authored groom\n"
           "  nn_gain             baselines, SPH parameters' scenarios (%s, ...), all with --nn:\n"
           "                      mean distance of each vertex to the nearest vertex of another strand\n"
           "                      at the end, with the scenario's parameters / with \"sph\" off, minus 1\n"
           "                      (volume the hair-hair interaction gives); null when not measured\n"
           "  steps_per_s         sim steps (with position read-back) per wall second, metrics excluded\n"
           "  nan_resets          strands the solver restored after a non-finite value\n"
           "Each groom ends with a summary line: the worst rest_p999, segment error and penetration\n"
           "and which scenario gave them. The default grid takes a few minutes on 2 cores.\n",
           BQ_BLEND_S, BQ_DEFAULT_STRANDS, BQ_DEFAULT_VERTS, BQ_DEFAULT_GROOM_FILE, BQ_SETTLE_MM,
           sph_param_names[0]);
}

typedef struct bq_opts {
    sim_backend_kind backend;
    const char *groom, *param, *groom_file, *collider_file;
    int preset; /* -1: cycle */
    uint32_t strands, verts;
    double seconds_motion, seconds_rest;
    int threads;
    bool nn, json, full;
} bq_opts;

/* The worst figures of one groom and the scenario that gave each. */
typedef struct bq_worst {
    double p999, seg, pen;
    char p999_at[96], seg_at[96], pen_at[96];
    int scenarios, unsettled;
} bq_worst;

/* A cached run with "sph" off, for nn_gain (the same groom, preset and other parameters). */
typedef struct bq_twin {
    sim_params params;
    app_preset preset;
    double nn;
} bq_twin;

#define BQ_MAX_TWINS 64

typedef struct bq_ctx {
    const bq_opts *o;
    const core_groom *g;
    const char *gname;
    double tips_authored;
    bq_worst worst;
    bq_twin twins[BQ_MAX_TWINS];
    int ntwins;
} bq_ctx;

/* Prints a double with fmt, or null when it is not finite (JSON). */
static void json_num(const char *key, const char *fmt, double v)
{
    printf(",\"%s\":", key);
    if (isfinite(v)) printf(fmt, v);
    else printf("null");
}

/* The mean nearest-other-strand distance of the scenario's run with "sph" off (cached). */
static core_status twin_nn(bq_ctx *c, const bq_scenario *sc, const core_param_info *tsph, double *out, core_err *err)
{
    bq_scenario off = *sc;
    bq_param_set(&off.params, tsph, 0.0);
    for (int i = 0; i < c->ntwins; i++)
        if (c->twins[i].preset == off.preset && bq_params_equal(&c->twins[i].params, &off.params)) {
            *out = c->twins[i].nn;
            return CORE_OK;
        }
    bq_result r;
    core_status st = bq_run(&off, &r, err);
    if (st != CORE_OK) return st;
    *out = r.nn_mean_m;
    if (c->ntwins < BQ_MAX_TWINS) c->twins[c->ntwins++] = (bq_twin){ off.params, off.preset, r.nn_mean_m };
    return CORE_OK;
}

static void print_row(const bq_ctx *c, const core_param_info *t, double value, app_preset preset, const bq_result *r,
                      double nn_gain, int32_t solver)
{
    const core_groom *g = c->g;
    if (c->o->json) {
        printf("{\"bench\":\"quality\",\"backend\":\"%s\",\"solver\":\"%s\",\"groom\":\"%s\",\"param\":\"%s\"",
               c->o->backend == SIM_BACKEND_VULKAN ? "vulkan" : "cpu", sim_solver_name(solver), c->gname,
               t ? t->name : "defaults");
        json_num("value", "%.6g", t ? value : NAN);
        printf(",\"preset\":\"%s\",\"strands\":%u,\"verts\":%u,\"seconds_motion\":%g,\"seconds_rest\":%g,"
               "\"settled\":%s",
               app_preset_names[preset], g->nstrands, g->nverts, c->o->seconds_motion, c->o->seconds_rest,
               r->settled ? "true" : "false");
        json_num("settle_s", "%.4f", r->settle_s);
        json_num("rest_p999_mm", "%.6f", r->rest_p999_mm);
        json_num("segment_error_max", "%.6f", r->segment_error_max);
        json_num("penetration_max_mm", "%.4f", r->penetration_max_mm);
        json_num("shape_deviation", "%.5f", r->shape_deviation);
        json_num("tips_above_roots", "%.4f", r->tips_above_roots);
        json_num("tips_above_roots_authored", "%.4f", c->tips_authored);
        json_num("nn_gain", "%.4f", nn_gain);
        json_num("nn_mean_mm", "%.4f", 1e3 * r->nn_mean_m);
        json_num("steps_per_s", "%.1f", r->steps_per_s);
        printf(",\"steps\":%llu,\"nan_resets\":%llu}\n", (unsigned long long)r->steps,
               (unsigned long long)r->nan_resets);
    } else {
        char pv[64], settle[16], nn[16];
        if (t) snprintf(pv, sizeof pv, "%s=%.4g", t->name, value);
        else snprintf(pv, sizeof pv, "defaults");
        snprintf(settle, sizeof settle, "%s%.2f", r->settled ? "" : ">", r->settle_s);
        if (isnan(nn_gain)) snprintf(nn, sizeof nn, "-");
        else snprintf(nn, sizeof nn, "%+.3f", nn_gain);
        printf("%-8s %-24s %-8s %7s %10.4f %9.5f %8.3f %8.4f %5.2f/%4.2f %7s %8.1f%s\n", c->gname, pv,
               app_preset_names[preset], settle, r->rest_p999_mm, r->segment_error_max, r->penetration_max_mm,
               r->shape_deviation, r->tips_above_roots, c->tips_authored, nn, r->steps_per_s,
               r->nan_resets ? "  NaN resets!" : "");
    }
    fflush(stdout);
}

/* Raises *w to x (noting where) when x is worse; a NaN is the worst of all and stays. */
static void raise_worst(double *w, char *at, size_t cap, double x, const char *where)
{
    if (isnan(*w) || !(isnan(x) || x > *w)) return;
    *w = x;
    snprintf(at, cap, "%s", where);
}

/* Notes one scenario's figures in the groom's worst. */
static void note_worst(bq_worst *w, const char *at, const bq_result *r)
{
    w->scenarios++;
    w->unsettled += !r->settled;
    raise_worst(&w->p999, w->p999_at, sizeof w->p999_at, r->rest_p999_mm, at);
    raise_worst(&w->seg, w->seg_at, sizeof w->seg_at, r->segment_error_max, at);
    raise_worst(&w->pen, w->pen_at, sizeof w->pen_at, r->penetration_max_mm, at);
}

/* Runs one scenario, prints its row and notes its figures. Returns 0, or 1 on failure. */
/* Whether parameter t applies to solver (every solver when t names none). */
static bool solver_applies(const core_param_info *t, int32_t solver)
{
    if (!t->solvers) return true;
    for (const char *const *n = t->solvers; *n; n++)
        if (strcmp(*n, sim_solver_name(solver)) == 0) return true;
    return false;
}

/* The hair-mesh solver's parameters need a hair-mesh groom, which the quality grooms are not
 * (strandbench hairmesh and test_sim_hm take them to their ends). */
static bool hairmesh_only(const core_param_info *t)
{
    return t->solvers && strcmp(t->solvers[0], "hairmesh") == 0 && !t->solvers[1];
}

static int run_scenario(bq_ctx *c, const core_param_info *t, double value, app_preset preset)
{
    bq_scenario sc = { .groom = c->g, .preset = preset, .seconds_motion = c->o->seconds_motion,
                       .seconds_rest = c->o->seconds_rest, .backend = c->o->backend, .threads = c->o->threads };
    memset(&sc.params, 0, sizeof sc.params);
    sim_params_default(&sc.params);
    if (t) bq_param_set(&sc.params, t, value);
    /* a parameter of another solver than the default runs under the first it applies to */
    if (t && t->solvers && !solver_applies(t, sc.params.solver))
        sc.params.solver = core_param_choice(bq_param_find("solver"), t->solvers[0]);
    const core_param_info *tsph = bq_param_find("sph");
    sc.want_nn = tsph && (c->o->nn || !t || is_sph_param(t->name));
    bq_result r;
    core_err err;
    double nn_gain = NAN, off = NAN;
    core_status st = bq_run(&sc, &r, &err);
    if (st == CORE_OK && sc.want_nn) st = twin_nn(c, &sc, tsph, &off, &err);
    if (st != CORE_OK) {
        fprintf(stderr, "strandbench quality: %s %s=%g %s: %s\n", c->gname, t ? t->name : "defaults", value,
                app_preset_names[preset], err.msg);
        return 1;
    }
    if (sc.want_nn && off > 0.0) nn_gain = r.nn_mean_m / off - 1.0;
    print_row(c, t, value, preset, &r, nn_gain, sc.params.solver);
    char at[96];
    if (t) snprintf(at, sizeof at, "%s=%g %s", t->name, value, app_preset_names[preset]);
    else snprintf(at, sizeof at, "defaults %s", app_preset_names[preset]);
    note_worst(&c->worst, at, &r);
    return 0;
}

static void print_summary(const bq_ctx *c)
{
    const bq_worst *w = &c->worst;
    if (c->o->json) {
        printf("{\"bench\":\"quality_summary\",\"groom\":\"%s\",\"scenarios\":%d,\"unsettled\":%d", c->gname,
               w->scenarios, w->unsettled);
        json_num("worst_rest_p999_mm", "%.6f", w->p999);
        printf(",\"worst_rest_p999_at\":\"%s\"", w->p999_at);
        json_num("worst_segment_error", "%.6f", w->seg);
        printf(",\"worst_segment_error_at\":\"%s\"", w->seg_at);
        json_num("worst_penetration_mm", "%.4f", w->pen);
        printf(",\"worst_penetration_at\":\"%s\"}\n", w->pen_at);
    } else {
        printf("== %s: %d scenarios, %d unsettled; worst rest p99.9 %.4f mm (%s); worst segment error %.5f (%s); "
               "worst penetration %.3f mm (%s)\n",
               c->gname, w->scenarios, w->unsettled, w->p999, w->p999_at, w->seg, w->seg_at, w->pen, w->pen_at);
    }
    fflush(stdout);
}

/* Every selected scenario of one groom. Returns 0, or 1 when any failed. */
static int run_groom(const bq_opts *o, const core_groom *g, const char *gname)
{
    bq_ctx *c = calloc(1, sizeof *c);
    if (!c) return 1;
    *c = (bq_ctx){ .o = o, .g = g, .gname = gname,
                   .tips_authored = quality_tips_above_roots(g->pos, g->nstrands, g->nverts),
                   .worst = { .p999 = -INFINITY, .seg = -INFINITY, .pen = -INFINITY } };
    if (!o->json)
        printf("# %s: %u strands x %u vertices, mean strand length %.1f mm, %u colliders\n", gname, g->nstrands,
               g->nverts, 1e3 * quality_mean_strand_length(g), g->ncolliders);
    size_t n;
    const core_param_info *table = sim_param_table(&n);
    int rc = 0, k = 0, matched = 0;
    /* baselines: every parameter at its default, under each preset (or the one asked for) */
    bool baselines = !o->param && !o->full;
    for (int p = 0; baselines && p < APP_PRESET_COUNT; p++)
        if (o->preset < 0 || o->preset == p) rc |= run_scenario(c, NULL, 0.0, (app_preset)p);
    for (size_t i = 0; i < n; i++) {
        const core_param_info *t = &table[i];
        if (o->param && strcmp(o->param, t->name) != 0) continue;
        matched++;
        if (hairmesh_only(t)) {
            if (o->param) {
                fprintf(stderr, "strandbench quality: %s is a hair-mesh solver parameter; the quality grooms are strand "
                                "grooms (strandbench hairmesh measures that solver)\n", t->name);
                rc = 1;
            }
            continue;
        }
        double vals[3] = { t->min, t->def, t->max };
        int nvals = 3;
        if (t->type == CORE_PARAM_BOOL) {
            vals[0] = 0.0;
            vals[1] = 1.0;
            nvals = 2;
        }
        for (int j = 0; j < nvals; j++) {
            if (j > 0 && vals[j] == vals[j - 1]) continue; /* a default at a bound */
            if (baselines && vals[j] == t->def) continue;  /* a baseline row already */
            app_preset preset = o->preset >= 0 ? (app_preset)o->preset : (app_preset)(k % APP_PRESET_COUNT);
            k++;
            rc |= run_scenario(c, t, vals[j], preset);
        }
    }
    if (!matched) {
        fprintf(stderr, "strandbench quality: no parameter '%s' in the table\n", o->param);
        rc = 1;
    }
    print_summary(c);
    free(c);
    return rc;
}

#define PROG "strandbench quality"

enum { OPT_JSON = 256, OPT_NN, OPT_FULL, OPT_BACKEND, OPT_GROOM, OPT_PARAM, OPT_GROOM_FILE, OPT_COLLIDER_FILE, OPT_PRESET,
       OPT_STRANDS, OPT_VERTS, OPT_THREADS, OPT_SECONDS_MOTION, OPT_SECONDS_REST };

static const struct option quality_options[] = {
    { "json", no_argument, NULL, OPT_JSON },
    { "nn", no_argument, NULL, OPT_NN },
    { "full", no_argument, NULL, OPT_FULL },
    { "backend", required_argument, NULL, OPT_BACKEND },
    { "groom", required_argument, NULL, OPT_GROOM },
    { "param", required_argument, NULL, OPT_PARAM },
    { "groom-file", required_argument, NULL, OPT_GROOM_FILE },
    { "collider-file", required_argument, NULL, OPT_COLLIDER_FILE },
    { "preset", required_argument, NULL, OPT_PRESET },
    { "strands", required_argument, NULL, OPT_STRANDS },
    { "verts", required_argument, NULL, OPT_VERTS },
    { "threads", required_argument, NULL, OPT_THREADS },
    { "seconds-motion", required_argument, NULL, OPT_SECONDS_MOTION },
    { "seconds-rest", required_argument, NULL, OPT_SECONDS_REST },
    { "help", no_argument, NULL, 'h' },
    { NULL, 0, NULL, 0 },
};

/* Parses argv into *o; returns -1 to go on, else the exit code. */
static int parse_args(int argc, char **argv, bq_opts *o)
{
    core_cli_begin();
    char flag[32];
    int opt, status;
    while ((opt = core_cli_next(PROG, argc, argv, quality_options, flag, sizeof flag, &status)) > 0) {
        const char *v = optarg;
        unsigned long long u = 0;
        int rc = 0;
        switch (opt) {
        case 'h': usage(); return 0;
        case OPT_JSON: o->json = true; break;
        case OPT_NN: o->nn = true; break;
        case OPT_FULL: o->full = true; break;
        case OPT_BACKEND:
            if (strcmp(v, "cpu") == 0) o->backend = SIM_BACKEND_CPU;
            else if (strcmp(v, "vulkan") == 0) o->backend = SIM_BACKEND_VULKAN;
            else return core_cli_bad(PROG, flag, v, "expected cpu or vulkan");
            break;
        case OPT_GROOM: o->groom = v; break;
        case OPT_PARAM: o->param = v; break;
        case OPT_GROOM_FILE: o->groom_file = v; break;
        case OPT_COLLIDER_FILE: o->collider_file = v; break;
        case OPT_PRESET:
            o->preset = -1;
            for (int p = 0; p < APP_PRESET_COUNT; p++)
                if (strcmp(v, app_preset_names[p]) == 0) o->preset = p;
            if (o->preset < 0) return core_cli_bad(PROG, flag, v, "expected none, nod, shake, circle, headbang or sway");
            break;
        case OPT_STRANDS:
            if (!(rc = core_cli_u64(PROG, flag, v, 1, GROOM_MAX_STRANDS, &u))) o->strands = (uint32_t)u;
            break;
        case OPT_VERTS:
            if (!(rc = core_cli_u64(PROG, flag, v, 2, GROOM_MAX_STRANDS, &u))) o->verts = (uint32_t)u;
            break;
        case OPT_THREADS:
            if (!(rc = core_cli_u64(PROG, flag, v, 1, 1024, &u))) o->threads = (int)u;
            break;
        case OPT_SECONDS_MOTION: rc = core_cli_f64(PROG, flag, v, 0.0, 3600.0, &o->seconds_motion); break;
        case OPT_SECONDS_REST: rc = core_cli_f64(PROG, flag, v, 0.05, 3600.0, &o->seconds_rest); break;
        }
        if (rc) return rc;
    }
    return status ? status : -1;
}

/* Gives g the collision mesh at path and its distance grid over groom_collider_region. */
static core_status attach_collider(core_groom *g, const char *path, core_err *err)
{
    g->mesh = calloc(1, sizeof *g->mesh);
    g->sdf = calloc(1, sizeof *g->sdf);
    if (!g->mesh || !g->sdf) return core_fail(err, CORE_ENOMEM, "out of memory for the collision mesh");
    core_status st = groom_mesh_load_file(path, g->mesh, err);
    core_vec3 lo, hi;
    if (st != CORE_OK) return st;
    if (!groom_collider_region(g, g->mesh, &lo, &hi)) { /* out of the hair's reach: no grid */
        free(g->sdf);
        g->sdf = NULL;
        return CORE_OK;
    }
    const groom_sdf_desc sd = { .cell = GROOM_SDF_DEFAULT_CELL, .lo = lo, .hi = hi, .max_cells = GROOM_COLLIDER_MAX_CELLS };
    return groom_sdf_build(g->mesh, &sd, g->sdf, err);
}

int bench_quality_main(int argc, char **argv)
{
    bq_opts o = { .backend = SIM_BACKEND_CPU, .groom_file = BQ_DEFAULT_GROOM_FILE, .preset = -1,
                  .strands = BQ_DEFAULT_STRANDS, .verts = BQ_DEFAULT_VERTS, .seconds_motion = 2.0, .seconds_rest = 3.0 };
    int rc = parse_args(argc, argv, &o);
    if (rc >= 0) return rc;
    rc = 0;
    static const char *const names[BQ_MAX_GROOMS] = { "straight", "wavy", "curly", "ratboy" };
    bool any = false;
    for (int k = 0; k < BQ_MAX_GROOMS; k++) any |= !o.groom || strcmp(o.groom, names[k]) == 0;
    if (!any) {
        fprintf(stderr, "strandbench quality: unknown groom '%s' (straight, wavy, curly, ratboy)\n", o.groom);
        return 2;
    }
    unsigned long long t0 = core_now_ns();
    if (!o.json)
        printf("%-8s %-24s %-8s %7s %10s %9s %8s %8s %10s %7s %8s\n", "groom", "param=value", "preset", "settle",
               "rest_p999", "seg_err", "pen_mm", "shape", "tips_up/au", "nn_gain", "steps/s");
    for (int k = 0; k < BQ_MAX_GROOMS; k++) {
        if (o.groom && strcmp(o.groom, names[k]) != 0) continue;
        core_groom g;
        core_err err;
        core_status st;
        if (k < 3) {
            groom_desc gd = { .style = (groom_style)k, .nstrands = o.strands, .nverts = o.verts };
            st = groom_procedural(&gd, &g, &err);
        } else {
            FILE *f = fopen(o.groom_file, "rb");
            if (!f) {
                if (o.json) printf("{\"bench\":\"quality_note\",\"groom\":\"ratboy\",\"skipped\":\"no file at %s\"}\n", o.groom_file);
                else printf("# ratboy skipped: no groom file at %s (--groom-file PATH)\n", o.groom_file);
                continue;
            }
            fclose(f);
            st = groom_load_file(o.groom_file, o.verts, &g, &err);
            if (st == CORE_OK && o.collider_file) st = attach_collider(&g, o.collider_file, &err);
        }
        if (st != CORE_OK) {
            fprintf(stderr, "strandbench quality: groom %s: %s\n", names[k], err.msg);
            rc = 1;
            continue;
        }
        rc |= run_groom(&o, &g, names[k]);
        core_groom_free(&g);
    }
    if (!o.json) printf("# total %.1f s wall\n", (double)(core_now_ns() - t0) * 1e-9);
    return rc;
}
