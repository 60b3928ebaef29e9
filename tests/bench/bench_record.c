/* strandbench record: what strandcastd --record costs the sim thread, on the daemon's default
 * scene: steps with and without recording, back to back, and the recording calls timed alone. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/app_anim.h"
#include "app/app_groom.h"
#include "app/app_record.h"
#include "bench.h"
#include "core/cli.h"
#include "groom/groom.h"

static void usage(void)
{
    puts("usage: strandbench record [--steps N] [--rounds R] [--threads N] [--strands N] [--verts N] [--digests]\n"
         "Steps the daemon's default scene (straight, 4096 x 32, default parameters, C backend) as the\n"
         "sim thread does (head animation, motion, step) in rounds of N steps (default 120), alternating\n"
         "without and with recording (R rounds of each, default 3, ABBA order). The recording round\n"
         "records what a client streaming its head pose every step makes the daemon record: one motion\n"
         "input per step (more than any live session: inputs are usually far rarer), to a file in /tmp\n"
         "written by app_record's writer thread. Prints the step time of both, their ratio, and the time\n"
         "of the recording calls themselves (encoding + handing over; timed alone, they are the sim\n"
         "thread's whole cost) as a fraction of the step time: the budget is 2%. --digests adds a\n"
         "position read-back and digest per step (--record-digests), which is not in that budget.");
}

typedef struct bench_rec {
    sim s;
    app_anim anim;
    float *xyz;
    size_t n;
    app_record rec;
    proto_parser parser;
    uint64_t step;
    double rec_ns;
} bench_rec;

/* One round of steps; recording when rec; returns the mean step ms (recording included). */
static double round_ms(bench_rec *b, int steps, bool rec, bool digests, double dt)
{
    unsigned long long t0 = core_now_ns();
    for (int i = 0; i < steps; i++) {
        app_anim_advance(&b->anim, dt);
        core_xform pose = app_anim_pose(&b->anim);
        sim_set_motion(&b->s, pose);
        core_err err;
        if (sim_step(&b->s, &err) != CORE_OK) {
            fprintf(stderr, "strandbench record: step failed: %s\n", err.msg);
            exit(1);
        }
        b->step++;
        if (!rec) continue;
        unsigned long long r0 = core_now_ns();
        proto_msg m;
        memset(&m, 0, sizeof m);
        m.type = PROTO_MOTION;
        m.u.motion.position = pose.pos;
        m.u.motion.orientation = pose.rot;
        app_record_input(&b->rec, b->step, &m);
        if (digests) {
            sim_read_positions(&b->s, b->xyz, &err);
            app_record_digest(&b->rec, b->step, app_rec_digest(b->xyz, b->n * 3));
        }
        b->rec_ns += (double)(core_now_ns() - r0);
    }
    return (double)(core_now_ns() - t0) / 1e6 / steps;
}

int bench_record_main(int argc, char **argv)
{
    int steps = 120, rounds = 3, threads = 0;
    unsigned long long strands = GROOM_DEFAULT_STRANDS, verts = GROOM_DEFAULT_VERTS;
    bool digests = false;
    for (int i = 1; i < argc; i++) {
        unsigned long long u;
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0) {
            usage();
            return 0;
        } else if (strcmp(a, "--digests") == 0) {
            digests = true;
        } else if (v && strcmp(a, "--steps") == 0 && !core_cli_u64("strandbench record", a, v, 1, 100000, &u)) {
            steps = (int)u, i++;
        } else if (v && strcmp(a, "--rounds") == 0 && !core_cli_u64("strandbench record", a, v, 1, 1000, &u)) {
            rounds = (int)u, i++;
        } else if (v && strcmp(a, "--threads") == 0 && !core_cli_u64("strandbench record", a, v, 1, 256, &u)) {
            threads = (int)u, i++;
        } else if (v && strcmp(a, "--strands") == 0 && !core_cli_u64("strandbench record", a, v, 1, 1 << 20, &u)) {
            strands = u, i++;
        } else if (v && strcmp(a, "--verts") == 0 && !core_cli_u64("strandbench record", a, v, 2, 256, &u)) {
            verts = u, i++;
        } else {
            usage();
            return 2;
        }
    }
    bench_rec *b = calloc(1, sizeof *b);
    app_groom g = { 0 };
    core_err err;
    sim_params p;
    sim_params_default(&p);
    sim_desc sd = { .backend = SIM_BACKEND_CPU, .threads = threads };
    if (!b || app_groom_load_style("straight", (uint32_t)strands, (uint32_t)verts, 0, &g, &err) != CORE_OK ||
        sim_create(&b->s, &sd, &g.g, &p, &err) != CORE_OK) {
        fprintf(stderr, "strandbench record: %s\n", b ? err.msg : "out of memory");
        return 1;
    }
    b->n = (size_t)strands * verts;
    b->xyz = malloc(b->n * 3 * sizeof *b->xyz);
    app_anim_init(&b->anim);
    app_anim_start(&b->anim, APP_PRESET_NOD, 1.0); /* the head moves: every motion differs */
    size_t nparams;
    const core_param_info *table = sim_param_table(&nparams);
    static const char *styles[] = { "straight", "wavy", "curly" };
    b->parser = (proto_parser){ table, nparams, app_preset_names, APP_PRESET_COUNT, styles, 3 };
    char path[64];
    snprintf(path, sizeof path, "/tmp/strandbench_record_%d.screc", (int)getpid());
    app_rec_start s = { .groom = "straight", .strands = (uint32_t)strands, .verts = (uint32_t)verts, .backend = SIM_BACKEND_CPU,
                        .threads = threads, .params = p };
    if (app_record_open(&b->rec, path, &s, &b->parser, digests, &err) != CORE_OK) {
        fprintf(stderr, "strandbench record: %s\n", err.msg);
        return 1;
    }
    round_ms(b, steps / 4 + 1, false, false, p.dt); /* warm up */
    double off = 0.0, on = 0.0;
    for (int r = 0; r < rounds; r++) { /* ABBA: drift of a shared machine cancels */
        bool first_on = r % 2 == 1;
        double a = round_ms(b, steps, first_on, digests, p.dt), c = round_ms(b, steps, !first_on, digests, p.dt);
        off += first_on ? c : a;
        on += first_on ? a : c;
        printf("round %d: step %.3f ms without recording, %.3f ms with\n", r + 1, first_on ? c : a, first_on ? a : c);
    }
    off /= rounds;
    on /= rounds;
    app_record_close(&b->rec, b->step);
    double rec_ms = b->rec_ns / 1e6 / ((double)rounds * steps);
    printf("scene %llu x %llu, %d substeps, C backend, %d rounds of %d steps%s\n", strands, verts, p.substeps, rounds, steps,
           digests ? ", with a digest per step" : "");
    printf("step without recording %.3f ms, with %.3f ms: ratio %.4f\n", off, on, on / off);
    printf("recording calls %.5f ms per step = %.4f%% of the step (budget 2%%)\n", rec_ms, 100.0 * rec_ms / off);
    remove(path);
    sim_destroy(&b->s);
    app_groom_free(&g);
    free(b->xyz);
    free(b);
    return 0;
}
