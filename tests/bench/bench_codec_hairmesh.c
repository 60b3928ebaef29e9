/* strandbench codec --hairmesh: bytes per frame of one hairstyle streamed as strands (codec id
 * 1, the guides traced through the hair mesh) and as the hair mesh itself (codec id 2), at 0.5,
 * 0.1 and 0.02 mm, on an animation of a procedural hair mesh (the head's synthetic motion and a
 * sway of the mesh growing from root to tip, the strands traced through every frame's mesh by
 * core_hairmesh_trace: what a viewer that grows its strands from the mesh draws), or on the
 * hair-mesh solver's frames under the same head motion (--sim: its strands and its mesh). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_codec_hairmesh.h"
#include "codec/codec.h"
#include "codec_synth.h"
#include "core/hairmesh_types.h"
#include "groom/groom.h"
#include "sim/sim.h"

#define NB 3
static const float BOUNDS_HM[NB] = { 5e-4f, 1e-4f, 2e-5f };

/* The mesh at time t: rest (column-major) swayed by an angle growing as s^2 along each column
 * (s = layer / (nlayers - 1)) about the vertical through its root, plus a forward swing, then
 * moved by the synthetic head motion. */
static void animate(const core_hairmesh *m, const float *rest, double t, float *out)
{
    double yaw, pitch, head[3];
    codec_synth_head(t, CODEC_SYNTH_GENTLE, &yaw, &pitch, head);
    const double yaxis[3] = { 0, 1, 0 }, xaxis[3] = { 1, 0, 0 };
    for (uint32_t c = 0; c < m->ncols; c++) {
        const float *r0 = rest + 3u * (size_t)c * m->nlayers;
        double phase = 4.0 * (double)r0[0] + 3.0 * (double)r0[2];
        for (uint32_t l = 0; l < m->nlayers; l++) {
            const float *r = rest + 3u * ((size_t)c * m->nlayers + l);
            double s = (double)l / (double)(m->nlayers - 1), a = 0.35 * s * s * sin(1.3 * t + phase);
            double d[3] = { (double)r[0] - r0[0], (double)r[1] - r0[1], (double)r[2] - r0[2] };
            codec_synth_rot(d, yaxis, a);
            codec_synth_rot(d, xaxis, 0.25 * s * s * sin(0.9 * t + 0.5 * phase));
            double w[3] = { r0[0] + d[0], r0[1] + d[1], r0[2] + d[2] };
            codec_synth_rot(w, xaxis, pitch);
            codec_synth_rot(w, yaxis, yaw);
            float *o = out + 3u * ((size_t)c * m->nlayers + l);
            for (int k = 0; k < 3; k++) o[k] = (float)(w[k] + head[k]);
        }
    }
}

/* The synthetic head at time t. */
static core_xform head_at(double t)
{
    const codec_sim_info h = codec_synth_sim(t, 0, CODEC_SYNTH_GENTLE);
    return (core_xform){ core_v3(h.head_pos[0], h.head_pos[1], h.head_pos[2]),
                         { h.head_rot[0], h.head_rot[1], h.head_rot[2], h.head_rot[3] } };
}

/* The next frame of the solver under the synthetic head at time t: its strands and its mesh. */
static core_status sim_frame(sim *s, double t, float *strands, float *mesh, core_err *err)
{
    sim_set_motion(s, head_at(t));
    core_status st = sim_step(s, err);
    if (st == CORE_OK) st = sim_read_positions(s, strands, err);
    if (st == CORE_OK) st = sim_read_hairmesh(s, mesh, err);
    return st;
}

int bench_codec_hairmesh(const bench_hairmesh_opts *o)
{
    core_err err;
    groom_style style;
    if (groom_style_parse(o->style, &style, &err) != CORE_OK) {
        fprintf(stderr, "strandbench codec: %s\n", err.msg);
        return 2;
    }
    core_hairmesh m;
    core_groom g = { 0 };
    groom_hairmesh_desc d = { .style = style, .grid = o->grid, .nlayers = o->nlayers };
    if (groom_hairmesh_procedural(&d, &m, &err) != CORE_OK || groom_from_hairmesh(&m, o->per_face, o->nverts, &g, &err) != CORE_OK) {
        fprintf(stderr, "strandbench codec: %s\n", err.msg);
        return 1;
    }
    const core_hairmesh *gm = g.hairmesh;
    sim s = { 0 };
    double fps = o->fps;
    if (o->sim) {
        sim_params p;
        sim_params_default(&p);
        p.solver = SIM_SOLVER_HAIRMESH;
        sim_desc sd = { .backend = SIM_BACKEND_CPU };
        if (sim_create(&s, &sd, &g, &p, &err) != CORE_OK) {
            fprintf(stderr, "strandbench codec: hair-mesh solver: %s\n", err.msg);
            return 1;
        }
        sim_set_motion(&s, head_at(0.0)); /* the hair starts at rest on the head, not 1.6 m below it */
        sim_reset(&s);
        fps = 1.0 / (double)p.dt;
    }
    const uint32_t nf = (uint32_t)lrint(o->seconds * fps), ns = g.nstrands, nv = g.nverts;
    const size_t nmesh = 3u * (size_t)m.ncols * m.nlayers, nstr = 3u * (size_t)ns * nv;
    float *mesh = malloc(nmesh * sizeof *mesh), *strands = malloc(nstr * sizeof *strands);
    float *back = malloc((nstr > nmesh ? nstr : nmesh) * sizeof *back);
    codec_encoder enc[2][NB];
    codec_decoder dec[2][NB];
    double bytes[2][NB] = { { 0 } }, maxerr[2][NB] = { { 0 } };
    codec_buf buf = { 0 };
    if (!mesh || !strands || !back || nf < 1) {
        fprintf(stderr, "strandbench codec: out of memory or no frames\n");
        return 1;
    }
    for (int k = 0; k < 2; k++)
        for (int b = 0; b < NB; b++) {
            codec_desc cd = { .max_error_m = BOUNDS_HM[b], .codec_id = k ? CODEC_ID_HAIRMESH : CODEC_ID_STRAND };
            if (codec_encoder_init(&enc[k][b], &cd, k ? m.ncols : ns, k ? m.nlayers : nv, &err) != CORE_OK) {
                fprintf(stderr, "strandbench codec: %s\n", err.msg);
                return 1;
            }
            codec_decoder_init(&dec[k][b]);
        }
    for (uint32_t f = 0; f < nf; f++) {
        double t = f / fps;
        if (o->sim) {
            if (sim_frame(&s, t, strands, mesh, &err) != CORE_OK) {
                fprintf(stderr, "strandbench codec: step %u: %s\n", f, err.msg);
                return 1;
            }
        } else {
            animate(&m, m.pos, t, mesh);
            for (uint32_t j = 0; j < ns; j++)
                core_hairmesh_trace(gm, mesh, gm->guide_face[j], gm->guide_uv[2 * j], gm->guide_uv[2 * j + 1], nv,
                                    gm->guide_t + (size_t)j * nv, strands + 3u * (size_t)j * nv);
        }
        codec_sim_info snap = codec_synth_sim(t, f, CODEC_SYNTH_GENTLE);
        for (int k = 0; k < 2; k++)
            for (int b = 0; b < NB; b++) {
                const float *x = k ? mesh : strands;
                size_t n = k ? nmesh : nstr;
                if (codec_encode(&enc[k][b], x, f + 1u, &snap, false, &buf, &err) != CORE_OK ||
                    codec_decode(&dec[k][b], buf.data, buf.len, back, n, NULL, &err) != CORE_OK) {
                    fprintf(stderr, "strandbench codec: frame %u: %s\n", f, err.msg);
                    return 1;
                }
                bytes[k][b] += (double)buf.len;
                for (size_t i = 0; i < n; i++) maxerr[k][b] = fmax(maxerr[k][b], fabs((double)back[i] - (double)x[i]));
            }
    }
    if (!o->json)
        printf("codec bench, one hairstyle as strands and as a hair mesh (%s): %u frames at %g/s, hair mesh %s %u x %u "
               "vertices (%u faces), %u strands x %u vertices traced through it\n%-9s %9s %14s %14s %12s %12s\n",
               o->sim ? "hair-mesh solver" : "animation", nf, fps, o->style, m.ncols, m.nlayers, m.nfaces, ns, nv, "source", "bound_mm", "bytes/frame",
               "kbit/s", "max_err_mm", "vs strands");
    for (int b = 0; b < NB; b++)
        for (int k = 0; k < 2; k++) {
            double per = bytes[k][b] / nf, ratio = bytes[k][b] / bytes[0][b];
            const char *name = k ? "hairmesh" : "strands";
            if (o->json)
                printf("{\"bench\":\"codec\",\"codec\":\"%s\",\"source\":\"hairmesh_%s%s\",\"error_bound_m\":%.6g,"
                       "\"bytes_per_frame\":%.1f,\"max_error_m\":%.6g,\"ratio_to_strands\":%.4f,\"frames\":%u,"
                       "\"vertices_per_frame\":%zu,\"hairmesh\":[%u,%u,%u],\"strands\":[%u,%u]}\n",
                       k ? "hairmesh" : "strand", o->style, o->sim ? "_sim" : "", (double)BOUNDS_HM[b], per, maxerr[k][b], ratio, nf,
                       (k ? nmesh : nstr) / 3u, m.ncols, m.nlayers, m.nfaces, ns, nv);
            else
                printf("%-9s %9.3f %14.1f %14.1f %12.6f %11.4fx\n", name, 1e3 * (double)BOUNDS_HM[b], per,
                       per * 8.0 * fps / 1e3, 1e3 * maxerr[k][b], ratio);
        }
    for (int k = 0; k < 2; k++)
        for (int b = 0; b < NB; b++) {
            codec_encoder_free(&enc[k][b]);
            codec_decoder_free(&dec[k][b]);
        }
    codec_buf_free(&buf);
    if (o->sim) sim_destroy(&s);
    free(mesh);
    free(strands);
    free(back);
    core_hairmesh_free(&m);
    core_groom_free(&g);
    return 0;
}
