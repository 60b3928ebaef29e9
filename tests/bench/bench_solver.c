/* strandbench solver: steps/s, ns per particle-step and memory-bandwidth fraction per case and
 * solver. */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/app_anim.h"
#include "bench.h"
#include "core/cli.h"
#include "groom/groom.h"
#include "sim/sim.h"
#include "sim/sim_step.h"
#include "sim/vk/sim_vk.h"

#define MAX_CASES 64

typedef struct bench_case {
    uint32_t strands, verts;
} bench_case;

static const bench_case default_cases[] = {
    /* the paper's Table 2 sizes, then its Table 1 scenes (strands x mean vertices) */
    { 1024, 8 }, { 1024, 32 }, { 4096, 32 }, { 4096, 64 }, { 16384, 64 },
    { 15000, 23 }, { 500, 16 }, { 3358, 10 }, { 2902, 12 }, { 496, 12 },
};

static const char *feature_names[] = { "dftl", "dftl+shape", "dftl+shape+sph" };
/* --solver names and their sim_solver values (hairmesh needs a hair-mesh groom: not benched here) */
static const char *const solver_names[] = { "dftl", "pbd" };
static const int solver_ids[] = { SIM_SOLVER_DFTL, SIM_SOLVER_PBD };

static void usage(void)
{
    puts("usage: strandbench [solver] [--backend cpu|vulkan|both] [--case SxV]... [--features dftl,dftl+shape,dftl+shape+sph]\n"
         "                  [--solver dftl,pbd] [--groom FILE] [--steps N] [--threads N] [--device N]\n"
         "                  [--substeps N] [--animate PRESET[,PRESET...]] [--json]\n"
         "Runs the solver on procedural grooms of each case (default: the paper's Table 2 sizes and\n"
         "Table 1 scenes) with each feature set, one step = one 1/60 s frame with one substep (the\n"
         "paper's Algorithm 1 per frame), and reports steps/s, ns per particle-step and the fraction\n"
         "of the memory bandwidth (a memcpy measured in the same run) the step's traffic reaches.\n"
         "--backend both runs each case on the C and the Vulkan backend and prints them side by side\n"
         "with the ratio; Vulkan rows carry the per-stage GPU time of the last step (timestamps).\n"
         "--solver dftl,pbd runs each case with each solver (default dftl), the PBD rows with the\n"
         "ratio of their steps/s to the DFTL row of the same case and features measured just before;\n"
         "PBD has no hair-hair interaction, so it runs the dftl and dftl+shape feature sets only (shape\n"
         "on or off, default pbd_iterations), on either backend.\n"
         "--device N picks the Vulkan device (0 = automatic, N >= 1 = vulkaninfo's GPU<N-1>);\n"
         "The SPH smoothing length is automatic (sph_radius 0: 1.75 x the groom's mean root spacing).\n"
         "--substeps N sets the solver substeps (default 1, the paper's; the daemon's default is 4).\n"
         "--animate runs each case once per head-motion preset (none, nod, shake, circle, headbang,\n"
         "sway: the daemon's presets, from the start of the preset) instead of the default slow turn,\n"
         "and prints each one's steps/s. C rows with SPH say how many of the timed steps' SPH passes\n"
         "searched the neighbours anew (\"searched S/P\"; the others kept the last lists). The daemon's default\n"
         "scene in real time: --case 4096x32 --features dftl+shape+sph --substeps 4\n"
         "--animate none,nod,shake,circle,headbang,sway (60 steps/s = real time).");
}

/* Bytes a step must move at least: per particle and substep the chain reads x, v, rest
 * (36 B) and writes x, v (24 B); with SPH it also reads a (12 B) and the SPH pass reads x, v
 * (24 B), writes and reads the sorted copies (2 x 44 B) and writes a (12 B). */
static double step_bytes(size_t n, int feat, int substeps)
{
    double per = 60.0 * substeps;
    if (feat == SIM_FEAT_SPH) per += 12.0 * substeps + 24.0 + 88.0 + 12.0;
    return per * (double)n;
}

typedef struct bench_opts {
    int threads, device, substeps;
    int solver;               /* sim_solver */
    int preset;               /* app_preset, or -1 for the default slow turn */
    bool json;
    double bandwidth;
} bench_opts;

typedef struct bench_result {
    double sps, ns_pp, bw;
    const char *backend;
    int substeps;
    float sph_radius;
    sim_stats stats; /* of the last step (per-stage GPU time for Vulkan) */
} bench_result;

static int measure(const core_groom *g, int feat, sim_backend_kind backend, const bench_opts *o, int steps,
                   bench_result *r)
{
    sim_params p;
    sim_params_default(&p);
    p.substeps = o->substeps;
    p.solver = o->solver;
    p.shape = feat >= SIM_FEAT_SHAPE;
    p.sph = feat >= SIM_FEAT_SPH;
    /* the default smoothing length is automatic: it follows the groom's root spacing */
    p.sph_radius = 0.0f;
    r->substeps = p.substeps;
    r->sph_radius = sim_sph_auto_radius(g);
    sim_desc d = { .backend = backend, .threads = o->threads, .device = o->device };
    sim s;
    core_err err;
    core_status st = backend == SIM_BACKEND_VULKAN ? sim_vk_create(&s, &d, NULL, g, &p, &err) : sim_create(&s, &d, g, &p, &err);
    if (st != CORE_OK) {
        fprintf(stderr, "strandbench: %ux%u %s: %s\n", g->nstrands, g->nverts, feature_names[feat], err.msg);
        return 1;
    }
    for (int i = 0; i < 3; i++) sim_step(&s, &err); /* warm up (first SPH pass computes rest density) */
    sim_get_stats(&s, &r->stats);                   /* waits for queued GPU work */
    const uint64_t passes0 = r->stats.sph_passes, searches0 = r->stats.sph_searches;
    unsigned long long t0 = core_now_ns();
    for (int i = 0; i < steps; i++) {
        core_xform h = core_xform_identity();
        if (o->preset >= 0)
            h = app_anim_head((app_preset)o->preset, (double)(i + 1) * p.dt, core_xform_identity());
        else
            h.rot = core_q_axis_angle(core_v3(0, 1, 0), 0.4f * (float)(i % 60) / 60.0f);
        sim_set_motion(&s, h);
        if (sim_step(&s, &err) != CORE_OK) {
            fprintf(stderr, "strandbench: step failed: %s\n", err.msg);
            sim_destroy(&s);
            return 1;
        }
    }
    sim_get_stats(&s, &r->stats); /* the GPU has finished every step when this returns */
    double sec = (double)(core_now_ns() - t0) * 1e-9;
    r->stats.sph_passes -= passes0; /* the timed steps' */
    r->stats.sph_searches -= searches0;
    size_t n = (size_t)g->nstrands * g->nverts;
    r->sps = steps / sec;
    r->ns_pp = sec * 1e9 / ((double)steps * (double)n);
    r->bw = step_bytes(n, feat, p.substeps) * r->sps / o->bandwidth;
    r->backend = s.vt->name;
    sim_destroy(&s);
    return 0;
}

static void print_result(const core_groom *g, int feat, const bench_opts *o, const bench_result *r, double vs_cpu,
                         double vs_dftl)
{
    if (o->json) {
        printf("{\"bench\":\"solver\",\"solver\":\"%s\",\"strands\":%u,\"verts\":%u,\"features\":\"%s\",\"backend\":\"%s\","
               "\"threads\":%d,\"steps_per_s\":%.2f,\"ns_per_particle_step\":%.3f,\"bw_fraction\":%.4f,"
               "\"memcpy_bytes_per_s\":%.4g,\"substeps\":%d,\"sph_radius_m\":%.5f,\"animate\":\"%s\"",
               sim_solver_name(o->solver), g->nstrands, g->nverts, feature_names[feat], r->backend, o->threads, r->sps,
               r->ns_pp, r->bw, o->bandwidth, r->substeps, r->sph_radius,
               o->preset >= 0 ? app_preset_names[o->preset] : "turn");
        if (vs_cpu > 0.0) printf(",\"vs_cpu\":%.3f", vs_cpu);
        if (vs_dftl > 0.0) printf(",\"vs_dftl\":%.3f", vs_dftl);
        if (r->stats.sph_passes > 0)
            printf(",\"sph_passes\":%llu,\"sph_searches\":%llu", (unsigned long long)r->stats.sph_passes,
                   (unsigned long long)r->stats.sph_searches);
        if (r->stats.nstages > 0) {
            printf(",\"stage_ms\":{");
            for (int k = 0; k < r->stats.nstages; k++)
                printf("%s\"%s\":%.4f", k ? "," : "", r->stats.stage_names[k], r->stats.stage_ms[k]);
            printf("}");
        }
        printf("}\n");
    } else {
        printf("%6u x %-3u %-4s %-15s %-7s %3d thr %10.1f steps/s %8.2f ns/particle-step  %5.1f%% of memcpy bw",
               g->nstrands, g->nverts, sim_solver_name(o->solver), feature_names[feat], r->backend, o->threads, r->sps,
               r->ns_pp, 100.0 * r->bw);
        if (vs_cpu > 0.0) printf("  %.2fx cpu", vs_cpu);
        if (vs_dftl > 0.0) printf("  %.3fx dftl", vs_dftl);
        if (o->preset >= 0) printf("  [%s]", app_preset_names[o->preset]);
        if (r->stats.sph_passes > 0)
            printf("  searched %llu/%llu", (unsigned long long)r->stats.sph_searches,
                   (unsigned long long)r->stats.sph_passes);
        printf("\n");
        if (strcmp(r->backend, "vulkan") == 0 && r->stats.nstages > 0) {
            printf("%31s", "gpu ms:");
            for (int k = 0; k < r->stats.nstages; k++)
                printf(" %s %.3f", r->stats.stage_names[k], r->stats.stage_ms[k]);
            printf("  (step %.3f)\n", r->stats.last_step_ms);
        }
    }
    fflush(stdout);
}

/* One case on one backend, or on both side by side (backend AUTO stands for both); *sps gets the
 * steps/s of the first backend's row, and dftl_sps > 0 is the DFTL row's to compare a PBD row
 * with. */
static int run_case(const core_groom *g, int feat, sim_backend_kind backend, const bench_opts *o, int steps,
                    double dftl_sps, double *sps)
{
    bench_result cpu, vk;
    if (backend != SIM_BACKEND_AUTO) {
        bench_result *r = backend == SIM_BACKEND_CPU ? &cpu : &vk;
        if (measure(g, feat, backend, o, steps, r) != 0) return 1;
        print_result(g, feat, o, r, 0.0, dftl_sps > 0.0 ? r->sps / dftl_sps : 0.0);
        *sps = r->sps;
        return 0;
    }
    if (measure(g, feat, SIM_BACKEND_CPU, o, steps, &cpu) != 0) return 1;
    print_result(g, feat, o, &cpu, 0.0, dftl_sps > 0.0 ? cpu.sps / dftl_sps : 0.0);
    *sps = cpu.sps;
    if (measure(g, feat, SIM_BACKEND_VULKAN, o, steps, &vk) != 0) return 1;
    print_result(g, feat, o, &vk, vk.sps / cpu.sps, 0.0);
    return 0;
}

#define PROG "strandbench"

enum { OPT_JSON = 256, OPT_CASE, OPT_FEATURES, OPT_BACKEND, OPT_DEVICE, OPT_SUBSTEPS, OPT_ANIMATE, OPT_GROOM, OPT_STEPS,
       OPT_THREADS, OPT_SOLVER };

static const struct option solver_options[] = {
    { "json", no_argument, NULL, OPT_JSON },         { "case", required_argument, NULL, OPT_CASE },
    { "features", required_argument, NULL, OPT_FEATURES }, { "backend", required_argument, NULL, OPT_BACKEND },
    { "device", required_argument, NULL, OPT_DEVICE },     { "substeps", required_argument, NULL, OPT_SUBSTEPS },
    { "animate", required_argument, NULL, OPT_ANIMATE },   { "groom", required_argument, NULL, OPT_GROOM },
    { "steps", required_argument, NULL, OPT_STEPS },       { "threads", required_argument, NULL, OPT_THREADS },
    { "solver", required_argument, NULL, OPT_SOLVER },     { "help", no_argument, NULL, 'h' },
    { NULL, 0, NULL, 0 },
};

/* Each comma-separated name of v found in names[0, n) into out (at most cap); 0 or the bad-flag status. */
static int parse_names(const char *flag, const char *v, const char *const *names, int n, int *out, int *count, int cap,
                       const char *expected)
{
    char buf[256];
    snprintf(buf, sizeof buf, "%s", v);
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        int k = 0;
        while (k < n && strcmp(tok, names[k]) != 0) k++;
        if (k == n || *count == cap) return core_cli_bad(PROG, flag, tok, expected);
        out[(*count)++] = k;
    }
    return 0;
}

int bench_solver_main(int argc, char **argv)
{
    bench_case cases[MAX_CASES];
    int ncases = 0, steps = 0, threads = 0, device = 0;
    bool json = false, feats[3] = { false, false, false }, any_feat = false;
    int substeps = 1, presets[APP_PRESET_COUNT], npresets = 0, solvers[2], nsolvers = 0;
    const char *groom_file = NULL;
    sim_backend_kind backend = SIM_BACKEND_CPU; /* AUTO here means both, side by side */
    core_cli_begin();
    char flag[32];
    int opt, status;
    while ((opt = core_cli_next(PROG, argc, argv, solver_options, flag, sizeof flag, &status)) > 0) {
        const char *v = optarg;
        unsigned long long u = 0;
        int rc = 0, fs[8], nf = 0;
        switch (opt) {
        case 'h': usage(); return 0;
        case OPT_JSON: json = true; break;
        case OPT_CASE: {
            unsigned s, n;
            char tail;
            if (ncases == MAX_CASES || sscanf(v, "%ux%u%c", &s, &n, &tail) != 2 || s == 0 || n < 2)
                return core_cli_bad(PROG, flag, v, "expected STRANDSxVERTS, e.g. 16384x64");
            cases[ncases++] = (bench_case){ s, n };
            break;
        }
        case OPT_FEATURES:
            rc = parse_names(flag, v, feature_names, 3, fs, &nf, 8, "expected dftl, dftl+shape or dftl+shape+sph");
            for (int k = 0; k < nf; k++) feats[fs[k]] = any_feat = true;
            break;
        case OPT_BACKEND:
            if (strcmp(v, "cpu") == 0) backend = SIM_BACKEND_CPU;
            else if (strcmp(v, "vulkan") == 0) backend = SIM_BACKEND_VULKAN;
            else if (strcmp(v, "both") == 0) backend = SIM_BACKEND_AUTO;
            else return core_cli_bad(PROG, flag, v, "expected cpu, vulkan or both");
            break;
        case OPT_DEVICE:
            if (!(rc = core_cli_u64(PROG, flag, v, 0, 64, &u))) device = (int)u;
            break;
        case OPT_SUBSTEPS:
            if (!(rc = core_cli_u64(PROG, flag, v, 1, SIM_MAX_SUBSTEPS, &u))) substeps = (int)u;
            break;
        case OPT_ANIMATE:
            rc = parse_names(flag, v, app_preset_names, APP_PRESET_COUNT, presets, &npresets, APP_PRESET_COUNT,
                             "expected presets: none, nod, shake, circle, headbang, sway");
            break;
        case OPT_SOLVER:
            rc = parse_names(flag, v, solver_names, 2, solvers, &nsolvers, 2, "expected solvers: dftl, pbd");
            break;
        case OPT_GROOM: groom_file = v; break;
        case OPT_STEPS:
            if (!(rc = core_cli_u64(PROG, flag, v, 1, 1000000, &u))) steps = (int)u;
            break;
        case OPT_THREADS:
            if (!(rc = core_cli_u64(PROG, flag, v, 1, 1000000, &u))) threads = (int)u;
            break;
        }
        if (rc) return rc;
    }
    if (status) return status;
    if (threads == 0) {
        long nc = sysconf(_SC_NPROCESSORS_ONLN);
        threads = nc > 0 ? (int)nc : 1;
    }
    if (!any_feat) feats[0] = feats[1] = feats[2] = true;
    if (ncases == 0 && !groom_file) {
        ncases = (int)(sizeof default_cases / sizeof default_cases[0]);
        memcpy(cases, default_cases, sizeof default_cases);
    }
    double bandwidth = bench_memcpy_bandwidth((size_t)256 << 20, threads);
    if (!json) printf("memcpy bandwidth: %.2f GB/s (read + write)\n", bandwidth * 1e-9);
    if (backend != SIM_BACKEND_CPU && !json) {
        sim_vk_probe_info info;
        core_err verr;
        if (sim_vk_probe(device, &info, &verr) == CORE_OK)
            printf("vulkan device: %s (%s)\n", info.device_name, info.hardware ? "GPU" : "CPU device");
    }
    if (npresets == 0) presets[npresets++] = -1;
    if (nsolvers == 0) solvers[nsolvers++] = 0;
    int rc = 0;
    int total = ncases + (groom_file ? 1 : 0);
    for (int c = 0; c < total; c++) {
        core_groom g;
        core_err err;
        core_status st;
        if (c < ncases) {
            groom_desc gd = { .nstrands = cases[c].strands, .nverts = cases[c].verts };
            st = groom_procedural(&gd, &g, &err);
        } else {
            st = groom_load_file(groom_file, 0, &g, &err);
        }
        if (st != CORE_OK) {
            fprintf(stderr, "strandbench: groom: %s\n", err.msg);
            return 1;
        }
        size_t n = (size_t)g.nstrands * g.nverts;
        int nsteps = steps ? steps : (int)(2e7 / (double)n) + 10;
        for (int f = 0; f < 3; f++) {
            if (!feats[f]) continue;
            for (int k = 0; k < npresets; k++) {
                double dftl_sps = 0.0;
                for (int v = 0; v < nsolvers; v++) {
                    const int solver = solver_ids[solvers[v]];
                    if (solver == SIM_SOLVER_PBD && f == SIM_FEAT_SPH) continue; /* no hair-hair interaction */
                    const bench_opts opts = { threads, device, substeps, solver, presets[k], json, bandwidth };
                    double sps = 0.0;
                    rc |= run_case(&g, f, backend, &opts, nsteps, solver == SIM_SOLVER_DFTL ? 0.0 : dftl_sps, &sps);
                    if (solver == SIM_SOLVER_DFTL) dftl_sps = sps;
                }
            }
        }
        core_groom_free(&g);
    }
    return rc;
}
