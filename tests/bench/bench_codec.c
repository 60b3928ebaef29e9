/* strandbench codec: bytes per vertex, max error and speed of the strand codec against
 * float32, quant+deflate and quant+meshopt+deflate (Node) at 0.5, 0.1 and 0.02 mm, on frames
 * of the CPU simulation (default groom, scripted head motion), a file or a synthetic animation. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <zlib.h>

#include "bench.h"
#include "bench_codec_hairmesh.h"
#include "codec/codec.h"
#include "codec_synth.h"
#include "core/cli.h"
#include "core/math3.h"
#include "groom/groom.h"
#include "sim/sim.h"

#define NBOUNDS 3
static const float BOUNDS[NBOUNDS] = { 5e-4f, 1e-4f, 2e-5f };

/* Frames: the simulation, a file ("SCFR", u32 nstrands, u32 nverts, u32 nframes, then float32
 * frames, strand-major xyz) or the synthetic animation. */
typedef struct frame_src {
    FILE *fp;
    int synthetic;
    sim sim;
    core_groom groom;
    uint32_t nstrands, nverts, nframes;
    double fps;
} frame_src;

/* The scripted head motion at time t: sway (yaw, pitch, roll) and drift, with a fast head
 * shake between 6 s and 7 s. */
static core_xform head_script(double t)
{
    const double tau = 6.283185307179586;
    double yaw = 0.5 * sin(tau * 0.4 * t), pitch = 0.15 * sin(tau * 0.6 * t), roll = 0.1 * sin(tau * 0.3 * t);
    if (t >= 6.0 && t < 7.0) yaw += 0.6 * sin(tau * 3.0 * (t - 6.0));
    core_xform x = core_xform_identity();
    x.pos = core_v3((float)(0.04 * sin(tau * 0.5 * t)), (float)(0.02 * sin(tau * 0.9 * t)), (float)(0.03 * sin(tau * 0.25 * t)));
    x.rot = core_q_mul(core_q_axis_angle(core_v3(0, 1, 0), (float)yaw),
                       core_q_mul(core_q_axis_angle(core_v3(1, 0, 0), (float)pitch),
                                  core_q_axis_angle(core_v3(0, 0, 1), (float)roll)));
    return x;
}

static int src_open_sim(frame_src *s, double seconds)
{
    core_err err;
    groom_desc gd = { 0 };
    sim_params params;
    sim_params_default(&params);
    if (groom_procedural(&gd, &s->groom, &err) || sim_create(&s->sim, NULL, &s->groom, &params, &err)) {
        fprintf(stderr, "strandbench codec: simulation: %s\n", err.msg);
        return -1;
    }
    s->nstrands = s->groom.nstrands;
    s->nverts = s->groom.nverts;
    s->fps = 1.0 / (double)params.dt;
    s->nframes = (uint32_t)lrint(seconds * s->fps);
    return 0;
}

static int src_open_file(frame_src *s, const char *path)
{
    s->fp = fopen(path, "rb");
    if (!s->fp) {
        fprintf(stderr, "strandbench codec: cannot open %s\n", path);
        return -1;
    }
    uint8_t h[16];
    if (fread(h, 1, 16, s->fp) != 16 || memcmp(h, "SCFR", 4) != 0) {
        fprintf(stderr, "strandbench codec: %s is not a frames file (magic SCFR)\n", path);
        return -1;
    }
    memcpy(&s->nstrands, h + 4, 4);
    memcpy(&s->nverts, h + 8, 4);
    memcpy(&s->nframes, h + 12, 4);
    if (s->nstrands < 1 || s->nverts < 2 || s->nverts > CODEC_MAX_NVERTS || s->nframes < 1 ||
        (uint64_t)s->nstrands * s->nverts > CODEC_MAX_VERTICES) {
        fprintf(stderr, "strandbench codec: %s has bad counts %u x %u x %u\n", path, s->nstrands, s->nverts, s->nframes);
        return -1;
    }
    return 0;
}

static int src_frame(frame_src *s, uint32_t f, float *xyz)
{
    size_t n = (size_t)s->nstrands * s->nverts * 3u;
    if (s->fp) {
        if (fread(xyz, sizeof *xyz, n, s->fp) != n) {
            fprintf(stderr, "strandbench codec: frames file ends at frame %u\n", f);
            return -1;
        }
        return 0;
    }
    if (s->synthetic) {
        codec_synth_frame(s->nstrands, s->nverts, f / s->fps, CODEC_SYNTH_GENTLE, xyz);
        return 0;
    }
    core_err err;
    sim_set_motion(&s->sim, head_script((f + 1) / s->fps));
    if (sim_step(&s->sim, &err) || sim_read_positions(&s->sim, xyz, &err)) {
        fprintf(stderr, "strandbench codec: simulation step %u: %s\n", f, err.msg);
        return -1;
    }
    return 0;
}

/* Per codec and bound: totals and per-frame times. */
typedef struct stat {
    double bytes, max_err;
    double *enc_ns, *dec_ns;
} stat;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, uint32_t n)
{
    qsort(v, n, sizeof *v, cmp_double);
    return n ? v[n / 2] : 0.0;
}

static double max_abs_err(const float *a, const float *b, size_t n)
{
    double m = 0;
    for (size_t i = 0; i < n; i++) {
        double e = fabs((double)a[i] - (double)b[i]);
        if (!(e <= m)) m = e;
    }
    return m;
}

/* The quant baseline: lattice in the frame's bounding box, step as the strand codec's. */
typedef struct quant {
    float lo[3];
    double step;
    uint32_t width;          /* bytes per integer: 2 or 4 */
    uint8_t *ints;           /* planar for deflate */
    uint8_t *inter;          /* interleaved for the meshopt dump */
    uint8_t *z;
    uLong zcap;
} quant;

static void quantize_bbox(quant *q, const float *x, size_t nv, float bound)
{
    float hi[3];
    for (int a = 0; a < 3; a++) q->lo[a] = hi[a] = x[a];
    for (size_t i = 0; i < nv; i++)
        for (int a = 0; a < 3; a++) {
            float v = x[3 * i + a];
            if (v < q->lo[a]) q->lo[a] = v;
            if (v > hi[a]) hi[a] = v;
        }
    q->step = 2.0 * (double)bound * (1.0 - 1.0 / 32.0);
    double levels = 0;
    for (int a = 0; a < 3; a++) levels = fmax(levels, ((double)hi[a] - q->lo[a]) / q->step + 1.0);
    q->width = levels < 65535.0 ? 2u : 4u;
    for (size_t i = 0; i < nv; i++)
        for (int a = 0; a < 3; a++) {
            uint32_t v = (uint32_t)lrint(((double)x[3 * i + a] - q->lo[a]) / q->step);
            size_t p = (size_t)a * nv + i, s = 3u * i + (size_t)a;
            if (q->width == 2) {
                ((uint16_t *)(void *)q->ints)[p] = (uint16_t)v;
                ((uint16_t *)(void *)q->inter)[s] = (uint16_t)v;
            } else {
                ((uint32_t *)(void *)q->ints)[p] = v;
                ((uint32_t *)(void *)q->inter)[s] = v;
            }
        }
}

static void dequantize_bbox(const quant *q, const uint8_t *ints, size_t nv, float *out)
{
    for (int a = 0; a < 3; a++)
        for (size_t i = 0; i < nv; i++) {
            size_t p = (size_t)a * nv + i;
            uint32_t v = q->width == 2 ? ((const uint16_t *)(const void *)ints)[p] : ((const uint32_t *)(const void *)ints)[p];
            out[3 * i + (size_t)a] = (float)((double)q->lo[a] + (double)v * q->step);
        }
}

static void put_u32(FILE *fp, uint32_t v)
{
    fwrite(&v, 4, 1, fp);
}

typedef struct js_result {
    int have_meshopt, have_strand;
    double mo_bytes, mo_enc, mo_dec, strand_dec, strand_key_dec;
    int bit_exact;
} js_result;

/* The clock the figures are taken with: the monotonic clock, or (cpu_time) this thread's CPU time,
 * which other jobs on a loaded host do not inflate. Nanoseconds. */
static unsigned long long bench_clock(int cpu_time)
{
    if (!cpu_time) return core_now_ns();
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (unsigned long long)ts.tv_sec * 1000000000ull + (unsigned long long)ts.tv_nsec;
}

/* Runs tests/bench/codec_js_bench.mjs on the dumps of one bound (cpu_time: as bench_clock). */
static void run_js(const char *quant_path, const char *strand_path, int cpu_time, js_result *r)
{
    memset(r, 0, sizeof *r);
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "node '%s/tests/bench/codec_js_bench.mjs' --quant '%s' --strand '%s'%s",
             STRANDCAST_SOURCE_DIR, quant_path, strand_path, cpu_time ? " --cpu-time" : "");
    FILE *p = popen(cmd, "r");
    if (!p) return;
    char line[1024];
    while (fgets(line, sizeof line, p)) {
        double a, b, c;
        int exact;
        if (sscanf(line, "{\"codec\":\"quant+meshopt+deflate\",\"bytes_per_vertex\":%lf,\"encode_ns_per_vertex\":%lf,"
                         "\"decode_ns_per_vertex\":%lf",
                   &a, &b, &c) == 3) {
            r->have_meshopt = 1;
            r->mo_bytes = a;
            r->mo_enc = b;
            r->mo_dec = c;
        } else if (sscanf(line, "{\"codec\":\"strand\",\"js_decode_ns_per_vertex\":%lf,\"bit_exact\":%d,"
                                "\"js_key_decode_ns_per_vertex\":%lf", &a, &exact, &b) == 3) {
            r->have_strand = 1;
            r->strand_dec = a;
            r->strand_key_dec = b;
            r->bit_exact = exact;
        } else {
            fputs(line, stderr);
        }
    }
    if (pclose(p) != 0) fprintf(stderr, "strandbench codec: the Node benchmark failed (node, npm meshoptimizer?)\n");
}

static void usage(void)
{
    puts("usage: strandbench codec [--json] [--frames FILE | --synthetic] [--seconds S] [--js-frames K] [--cpu-time]\n"
         "                         [--save-frames OUT]   (OUT: the frames used, in the FILE format)\n"
         "                         [--fps F] [--strands N] [--verts V]   (the last three: --synthetic only)\n"
         "  default: S seconds (10) of the CPU simulation on the default procedural groom with a\n"
         "        scripted head motion (sway, drift, a fast shake at 6-7 s), one frame per step.\n"
         "  FILE: \"SCFR\", u32 nstrands, u32 nverts, u32 nframes, then nframes x nstrands x nverts x 3\n"
         "        float32 (little-endian, strand-major xyz).\n"
         "  --synthetic: strands swinging on a sphere (default 4096 x 32 vertices at 60 frames/s).\n"
         "  K: consecutive frames from the middle (from a keyframe) also decoded in Node (strand, JS)\n"
         "     and coded with meshopt (default 30); the meshopt row and ratio use those frames.\n"
         "  --cpu-time: time with the CPU clock of the thread (C) and process (Node), not the wall\n"
         "     clock (for a host that other jobs load).\n"
         "  --hairmesh STYLE [--grid G] [--layers L] [--per-face P] [--verts V] [--seconds S] [--fps F] [--sim]:\n"
         "     bytes per frame of one hairstyle streamed as strands and as its hair mesh: a procedural\n"
         "     hair mesh (straight | wavy | curly, G x G quads per scalp patch (the generator's default),\n"
         "     L layers (9)) swaying under the synthetic head motion, P strands of V vertices per face\n"
         "     (114, 32) traced through it;\n"
         "     --sim: the hair-mesh solver's frames under that head motion instead (one per step).");
}

#define PROG "strandbench codec"

enum { OPT_JSON = 256, OPT_CPU_TIME, OPT_SYNTHETIC, OPT_SAVE_FRAMES, OPT_FRAMES, OPT_SECONDS, OPT_FPS, OPT_STRANDS, OPT_VERTS,
       OPT_JS_FRAMES, OPT_HAIRMESH, OPT_GRID, OPT_LAYERS, OPT_PER_FACE, OPT_SIM };

static const struct option codec_options[] = {
    { "json", no_argument, NULL, OPT_JSON },
    { "cpu-time", no_argument, NULL, OPT_CPU_TIME },
    { "synthetic", no_argument, NULL, OPT_SYNTHETIC },
    { "save-frames", required_argument, NULL, OPT_SAVE_FRAMES },
    { "frames", required_argument, NULL, OPT_FRAMES },
    { "seconds", required_argument, NULL, OPT_SECONDS },
    { "fps", required_argument, NULL, OPT_FPS },
    { "strands", required_argument, NULL, OPT_STRANDS },
    { "verts", required_argument, NULL, OPT_VERTS },
    { "js-frames", required_argument, NULL, OPT_JS_FRAMES },
    { "hairmesh", required_argument, NULL, OPT_HAIRMESH },
    { "grid", required_argument, NULL, OPT_GRID },
    { "layers", required_argument, NULL, OPT_LAYERS },
    { "per-face", required_argument, NULL, OPT_PER_FACE },
    { "sim", no_argument, NULL, OPT_SIM },
    { "help", no_argument, NULL, 'h' },
    { NULL, 0, NULL, 0 },
};

int bench_codec_main(int argc, char **argv)
{
    int json = 0, cpu_time = 0;
    const char *path = NULL;
    double seconds = 10.0;
    frame_src src = { .nstrands = 4096, .nverts = 32, .fps = 60.0 };
    uint32_t js_frames = 30;
    const char *save = NULL;
    bench_hairmesh_opts hm = { .nlayers = 9, .per_face = 114, .nverts = 32, .fps = 60.0 };
    core_cli_begin();
    char flag[32];
    int opt, status;
    while ((opt = core_cli_next(PROG, argc, argv, codec_options, flag, sizeof flag, &status)) > 0) {
        const char *v = optarg;
        unsigned long long u = 0;
        int rc = 0;
        switch (opt) {
        case 'h': usage(); return 0;
        case OPT_JSON: json = 1; break;
        case OPT_CPU_TIME: cpu_time = 1; break;
        case OPT_SYNTHETIC: src.synthetic = 1; break;
        case OPT_SAVE_FRAMES: save = v; break;
        case OPT_FRAMES: path = v; break;
        case OPT_SECONDS: rc = core_cli_f64(PROG, flag, v, 0.01, 3600.0, &seconds); break;
        case OPT_FPS: rc = core_cli_f64(PROG, flag, v, 1.0, 1000.0, &src.fps); break;
        case OPT_STRANDS:
            if (!(rc = core_cli_u64(PROG, flag, v, 1, 1u << 20, &u))) src.nstrands = (uint32_t)u;
            break;
        case OPT_VERTS:
            if (!(rc = core_cli_u64(PROG, flag, v, 2, 1024, &u))) src.nverts = (uint32_t)u;
            break;
        case OPT_JS_FRAMES:
            if (!(rc = core_cli_u64(PROG, flag, v, 0, 1000000, &u))) js_frames = (uint32_t)u;
            break;
        case OPT_HAIRMESH: hm.style = v; break;
        case OPT_SIM: hm.sim = 1; break;
        case OPT_GRID:
            if (!(rc = core_cli_u64(PROG, flag, v, 1, GROOM_HAIRMESH_MAX_GRID, &u))) hm.grid = (uint32_t)u;
            break;
        case OPT_LAYERS:
            if (!(rc = core_cli_u64(PROG, flag, v, 2, 1024, &u))) hm.nlayers = (uint32_t)u;
            break;
        case OPT_PER_FACE:
            if (!(rc = core_cli_u64(PROG, flag, v, 1, 4096, &u))) hm.per_face = (uint32_t)u;
            break;
        }
        if (rc) return rc;
    }
    if (status) return status;
    if (hm.style) {
        hm.json = json;
        hm.seconds = seconds;
        hm.fps = src.fps;
        hm.nverts = src.nverts;
        return bench_codec_hairmesh(&hm);
    }
    if (path) {
        if (src_open_file(&src, path)) return 1;
    } else if (!src.synthetic) {
        if (!(seconds > 0) || src_open_sim(&src, seconds)) return 1;
    } else {
        if (!(seconds > 0 && src.fps > 0) || src.nstrands < 1 || src.nverts < 2) {
            usage();
            return 2;
        }
        src.nframes = (uint32_t)lrint(seconds * src.fps);
    }
    const uint32_t nf = src.nframes;
    const size_t nv = (size_t)src.nstrands * src.nverts, n = nv * 3u;
    if (js_frames > nf) js_frames = nf;
    /* the Node sample: js_frames consecutive frames from the middle, starting at a keyframe */
    const uint32_t js_start = (nf - js_frames) / 2u / CODEC_DEFAULT_KEY_INTERVAL * CODEC_DEFAULT_KEY_INTERVAL;
    double strand_window[NBOUNDS] = { 0 };

    float *x = malloc(n * sizeof *x), *y = malloc(n * sizeof *y);
    codec_encoder enc[NBOUNDS];
    codec_decoder dec[NBOUNDS];
    codec_buf buf = { 0 };
    quant q = { .ints = malloc(n * 4u), .inter = malloc(n * 4u) };
    q.zcap = compressBound((uLong)(n * 4u));
    q.z = malloc(q.zcap);
    uint8_t *unz = malloc(n * 4u);
    enum { F32, QDEF, STRAND, NCODEC };
    stat st[NCODEC][NBOUNDS];
    memset(st, 0, sizeof st);
    for (int c = 0; c < NCODEC; c++)
        for (int b = 0; b < NBOUNDS; b++) {
            st[c][b].enc_ns = calloc(nf, sizeof(double));
            st[c][b].dec_ns = calloc(nf, sizeof(double));
        }
    char tmpdir[] = "/tmp/strandbench-codec-XXXXXX";
    if (!x || !y || !q.ints || !q.inter || !q.z || !unz || !mkdtemp(tmpdir)) {
        fprintf(stderr, "strandbench codec: out of memory or no temp dir\n");
        return 1;
    }
    FILE *saved = save ? fopen(save, "wb") : NULL;
    if (save && !saved) {
        fprintf(stderr, "strandbench codec: cannot write %s\n", save);
        return 1;
    }
    if (saved) {
        fwrite("SCFR", 1, 4, saved);
        put_u32(saved, src.nstrands);
        put_u32(saved, src.nverts);
        put_u32(saved, nf);
    }
    FILE *qdump[NBOUNDS], *sdump[NBOUNDS];
    char qpath[NBOUNDS][128], spath[NBOUNDS][128];
    for (int b = 0; b < NBOUNDS; b++) {
        core_err err;
        codec_desc d = { .max_error_m = BOUNDS[b] };
        if (codec_encoder_init(&enc[b], &d, src.nstrands, src.nverts, &err)) {
            fprintf(stderr, "strandbench codec: %s\n", err.msg);
            return 1;
        }
        codec_decoder_init(&dec[b]);
        snprintf(qpath[b], sizeof qpath[b], "%s/quant%d.bin", tmpdir, b);
        snprintf(spath[b], sizeof spath[b], "%s/strand%d.bin", tmpdir, b);
        qdump[b] = fopen(qpath[b], "wb");
        sdump[b] = fopen(spath[b], "wb");
        if (!qdump[b] || !sdump[b]) return 1;
        fwrite("SCQ1", 1, 4, qdump[b]);
        put_u32(qdump[b], (uint32_t)nv);
        put_u32(qdump[b], js_frames);
        fwrite("SCS1", 1, 4, sdump[b]);
        put_u32(sdump[b], js_frames);
    }

    for (uint32_t f = 0; f < nf; f++) {
        if (src_frame(&src, f, x)) return 1;
        if (saved && fwrite(x, sizeof *x, n, saved) != n) {
            fprintf(stderr, "strandbench codec: cannot write %s\n", save);
            return 1;
        }
        unsigned long long t0 = bench_clock(cpu_time);
        memcpy(y, x, n * sizeof *x);
        unsigned long long t1 = bench_clock(cpu_time);
        for (int b = 0; b < NBOUNDS; b++) {
            st[F32][b].enc_ns[f] = st[F32][b].dec_ns[f] = (double)(t1 - t0);
            st[F32][b].bytes += (double)(n * sizeof *x);
        }
        for (int b = 0; b < NBOUNDS; b++) {
            core_err err;
            /* strand */
            t0 = bench_clock(cpu_time);
            const codec_sim_info snap = { .sim_time = f / src.fps, .sim_step = f, .head_rot = { 0.0f, 0.0f, 0.0f, 1.0f } };
            if (codec_encode(&enc[b], x, f + 1u, &snap, false, &buf, &err)) {
                fprintf(stderr, "strandbench codec: frame %u: %s\n", f, err.msg);
                return 1;
            }
            t1 = bench_clock(cpu_time);
            if (codec_decode(&dec[b], buf.data, buf.len, y, n, NULL, &err)) {
                fprintf(stderr, "strandbench codec: frame %u: %s\n", f, err.msg);
                return 1;
            }
            unsigned long long t2 = bench_clock(cpu_time);
            st[STRAND][b].enc_ns[f] = (double)(t1 - t0);
            st[STRAND][b].dec_ns[f] = (double)(t2 - t1);
            st[STRAND][b].bytes += (double)buf.len;
            st[STRAND][b].max_err = fmax(st[STRAND][b].max_err, max_abs_err(x, y, n));
            int in_window = f >= js_start && f < js_start + js_frames;
            if (in_window) {
                strand_window[b] += (double)buf.len;
                put_u32(sdump[b], (uint32_t)buf.len);
                put_u32(sdump[b], (uint32_t)crc32(0L, (const Bytef *)y, (uInt)(n * sizeof *y)));
                fwrite(buf.data, 1, buf.len, sdump[b]);
            }
            /* quant + deflate (level 6) */
            t0 = bench_clock(cpu_time);
            quantize_bbox(&q, x, nv, BOUNDS[b]);
            uLongf zl = q.zcap;
            compress2(q.z, &zl, q.ints, (uLong)(n * q.width), 6);
            t1 = bench_clock(cpu_time);
            uLongf ul = (uLongf)(n * 4u);
            if (uncompress(unz, &ul, q.z, zl) != Z_OK || ul != n * q.width) return 1;
            dequantize_bbox(&q, unz, nv, y);
            t2 = bench_clock(cpu_time);
            st[QDEF][b].enc_ns[f] = (double)(t1 - t0);
            st[QDEF][b].dec_ns[f] = (double)(t2 - t1);
            st[QDEF][b].bytes += (double)zl + 32.0; /* + bounding box, step, counts */
            st[QDEF][b].max_err = fmax(st[QDEF][b].max_err, max_abs_err(x, y, n));
            if (in_window) {
                fwrite(q.lo, 4, 3, qdump[b]);
                fwrite(&q.step, 8, 1, qdump[b]);
                put_u32(qdump[b], q.width);
                fwrite(q.inter, q.width, n, qdump[b]);
            }
        }
    }
    for (int b = 0; b < NBOUNDS; b++) {
        fclose(qdump[b]);
        fclose(sdump[b]);
    }
    if (saved) fclose(saved);

    const char *names[NCODEC] = { "float32", "quant+deflate", "strand" };
    const char *source = path ? "file" : src.synthetic ? "synthetic" : "simulation";
    double vtot = (double)nv * nf;
    if (!json)
        printf("codec bench: %u frames of %u x %u vertices (%s), Node sample: frames %u..%u\n"
               "%-22s %9s %10s %12s %10s %10s %12s %12s\n", nf, src.nstrands, src.nverts, path ? path : source,
               js_start, js_start + js_frames - 1, "codec", "bound_mm", "B/vertex", "max_err_mm", "enc_ns/v", "dec_ns/v", "js_dec_ns/v",
               "js_key_ns/v");
    for (int b = 0; b < NBOUNDS; b++) {
        js_result js;
        run_js(qpath[b], spath[b], cpu_time, &js);
        double qerr = st[QDEF][b].max_err;
        /* strand bytes over each baseline's bytes on the same frames; the largest ratio is the
         * one to the best baseline */
        double ratio = st[STRAND][b].bytes / st[QDEF][b].bytes;
        if (js.have_meshopt) ratio = fmax(ratio, strand_window[b] / ((double)nv * js_frames) / js.mo_bytes);
        for (int c = 0; c < NCODEC + 1; c++) {
            const char *name;
            double bytes, err, e_ns, d_ns;
            if (c == NCODEC) {
                if (!js.have_meshopt) continue;
                name = "quant+meshopt+deflate";
                bytes = js.mo_bytes;
                err = qerr; /* the same lattice, coded losslessly */
                e_ns = js.mo_enc;
                d_ns = js.mo_dec;
            } else {
                name = names[c];
                bytes = st[c][b].bytes / vtot;
                err = st[c][b].max_err;
                e_ns = median(st[c][b].enc_ns, nf) / (double)nv;
                d_ns = median(st[c][b].dec_ns, nf) / (double)nv;
            }
            int strand = c == STRAND;
            if (json) {
                printf("{\"bench\":\"codec\",\"codec\":\"%s\",\"error_bound_m\":%.6g,\"bytes_per_vertex\":%.4f,"
                       "\"max_error_m\":%.6g,\"encode_ns_per_vertex\":%.2f,\"decode_ns_per_vertex\":%.2f,"
                       "\"frames\":%u,\"vertices_per_frame\":%zu,\"source\":\"%s\"",
                       name, (double)BOUNDS[b], bytes, err, e_ns, d_ns, c == NCODEC ? js_frames : nf, nv, source);
                if (strand) {
                    printf(",\"ratio_to_best_baseline\":%.3f", ratio);
                    if (js.have_strand)
                        printf(",\"js_decode_ns_per_vertex\":%.2f,\"js_key_decode_ns_per_vertex\":%.2f,\"js_bit_exact\":%s",
                               js.strand_dec, js.strand_key_dec,
                               js.bit_exact ? "true" : "false");
                }
                if (c == NCODEC) printf(",\"runtime\":\"node\"");
                puts("}");
            } else {
                printf("%-22s %9.3f %10.4f %12.6f %10.2f %10.2f", name, 1e3 * (double)BOUNDS[b], bytes, 1e3 * err, e_ns, d_ns);
                if (strand && js.have_strand)
                    printf(" %12.2f %12.2f%s", js.strand_dec, js.strand_key_dec, js.bit_exact ? "" : " (NOT bit-exact)");
                if (strand) printf("   %.3fx the best baseline", ratio);
                putchar('\n');
            }
        }
        remove(qpath[b]);
        remove(spath[b]);
        codec_encoder_free(&enc[b]);
        codec_decoder_free(&dec[b]);
    }
    rmdir(tmpdir);
    for (int c = 0; c < NCODEC; c++)
        for (int b = 0; b < NBOUNDS; b++) {
            free(st[c][b].enc_ns);
            free(st[c][b].dec_ns);
        }
    if (src.fp) fclose(src.fp);
    sim_destroy(&src.sim);
    core_groom_free(&src.groom);
    codec_buf_free(&buf);
    free(x);
    free(y);
    free(q.ints);
    free(q.inter);
    free(q.z);
    free(unz);
    return 0;
}
