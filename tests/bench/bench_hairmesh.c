/* strandbench hairmesh: the hair-mesh solver's milliseconds per frame and per stage on the 2016
 * paper's mesh sizes, against the paper's figures. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench.h"
#include "groom/groom.h"
#include "sim/hm/sim_hm.h"
#include "sim/sim.h"

/* The paper's sizes (215, 361 and 2,305 vertices; 4.8, about 6 and 36 ms per frame on one core
 * of a 3.2 GHz i7-3930K) as the nearest procedural meshes. */
typedef struct hm_case {
    uint32_t patches, grid, layers;
    double paper_ms;
    uint32_t paper_vertices;
} hm_case;

static const hm_case cases[] = {
    { 2, 2, 6, 4.8, 215 },   /* 4 patches x 9 columns x 6 layers = 216 */
    { 2, 2, 10, 6.0, 361 },  /* 4 x 9 x 10 = 360 */
    { 4, 3, 9, 36.0, 2305 }, /* 16 x 16 x 9 = 2,304 */
};

/* This thread's CPU time in ms: on a shared machine it leaves out the time other processes
 * take the core away (wall time is reported too). */
static double thread_cpu_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec * 1e3 + (double)t.tv_nsec * 1e-6;
}

static void usage(void)
{
    puts("usage: strandbench hairmesh [--frames N] [--substeps N] [--dt S] [--json]\n"
         "Runs the hair-mesh solver (one thread, as the paper) on procedural hair meshes of the 2016\n"
         "paper's sizes (216, 360 and 2,304 vertices for its 215, 361 and 2,305) with the default\n"
         "character's colliders while the head turns and nods (0.5 rad, 0.5 Hz), after 30 untimed\n"
         "frames, and reports ms per frame (one frame = one step of --dt, default 1/60 s, in\n"
         "--substeps substeps, default 1: the paper's large time steps), the per-stage times (forces,\n"
         "CG, collisions, deformation minimization: the paper's Figure 6; wall time) and the paper's\n"
         "figure over our thread CPU time per frame (which leaves out what other processes take on a\n"
         "shared machine). Default 300 timed frames.");
}

int bench_hairmesh_main(int argc, char **argv)
{
    int frames = 300, substeps = 1, json = 0;
    float dt = 1.0f / 60.0f;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--json") == 0) json = 1;
        else if (strcmp(argv[i], "--frames") == 0 && i + 1 < argc) frames = atoi(argv[++i]);
        else if (strcmp(argv[i], "--substeps") == 0 && i + 1 < argc) substeps = atoi(argv[++i]);
        else if (strcmp(argv[i], "--dt") == 0 && i + 1 < argc) dt = (float)atof(argv[++i]);
        else {
            usage();
            return strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0 ? 0 : 2;
        }
    }
    if (frames < 1) frames = 1;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const hm_case *k = &cases[c];
        core_err err;
        core_hairmesh m;
        core_groom g;
        groom_hairmesh_desc d = { .patches = k->patches, .grid = k->grid, .nlayers = k->layers };
        if (groom_hairmesh_procedural(&d, &m, &err) != CORE_OK || groom_from_hairmesh(&m, 4, 16, &g, &err) != CORE_OK) {
            fprintf(stderr, "strandbench hairmesh: %s\n", err.msg);
            return 1;
        }
        core_hairmesh_free(&m);
        groom_default_colliders(&g);
        sim_params p;
        sim_params_default(&p);
        p.dt = dt, p.substeps = substeps;
        sim s;
        if (sim_hm_open(&s, NULL, &g, &p, &err) != CORE_OK) {
            fprintf(stderr, "strandbench hairmesh: %s\n", err.msg);
            core_groom_free(&g);
            return 1;
        }
        const uint32_t nv = g.hairmesh->ncols * g.hairmesh->nlayers;
        double total = 0.0, cpu = 0.0, stage[4] = { 0 };
        sim_stats st;
        for (int f = 0; f < frames + 30; f++) {
            const float t = (float)(f + 1) * dt, w = 2.0f * 3.14159265f * 0.5f;
            core_xform head = core_xform_identity();
            head.rot = core_q_mul(core_q_axis_angle(core_v3(0.0f, 1.0f, 0.0f), 0.5f * sinf(w * t)),
                                  core_q_axis_angle(core_v3(1.0f, 0.0f, 0.0f), 0.25f * sinf(2.0f * w * t)));
            sim_set_motion(&s, head);
            const double c0 = thread_cpu_ms();
            if (sim_step(&s, &err) != CORE_OK) {
                fprintf(stderr, "strandbench hairmesh: step: %s\n", err.msg);
                sim_destroy(&s);
                core_groom_free(&g);
                return 1;
            }
            if (f < 30) continue;
            cpu += thread_cpu_ms() - c0;
            sim_get_stats(&s, &st);
            total += st.last_step_ms;
            for (int j = 0; j < 4; j++) stage[j] += st.stage_ms[j];
        }
        const double ms = total / frames;
        if (json)
            printf("{\"bench\":\"hairmesh\",\"vertices\":%u,\"paper_vertices\":%u,\"layers\":%u,\"substeps\":%d,"
                   "\"threads\":1,\"ms_per_frame\":%.4f,\"cpu_ms_per_frame\":%.4f,\"forces_ms\":%.4f,\"cg_ms\":%.4f,\"collisions_ms\":%.4f,"
                   "\"deform_min_ms\":%.4f,\"paper_ms\":%.1f,\"paper_over_ours_cpu\":%.2f}\n",
                   nv, k->paper_vertices, k->layers, substeps, ms, cpu / frames, stage[0] / frames, stage[1] / frames,
                   stage[2] / frames, stage[3] / frames, k->paper_ms, k->paper_ms / (cpu / frames));
        else
            printf("%5u vertices (paper %4u): %7.3f ms/frame (%.3f cpu)  forces %.3f  cg %.3f  collisions %.3f  deform_min %.3f"
                   "  | paper %.1f ms = %.1fx our cpu\n",
                   nv, k->paper_vertices, ms, cpu / frames, stage[0] / frames, stage[1] / frames, stage[2] / frames, stage[3] / frames,
                   k->paper_ms, k->paper_ms / (cpu / frames));
        sim_destroy(&s);
        core_groom_free(&g);
    }
    return 0;
}
