/* Synthetic strand animation for codec tests and benchmarks: strands hanging from roots on a
 * head sphere, swinging with time, segment lengths preserved, plus rigid head motion. */
#ifndef BENCH_CODEC_SYNTH_H
#define BENCH_CODEC_SYNTH_H

#include <math.h>
#include <stdint.h>

#include "codec/codec.h"

typedef enum codec_synth_style {
    CODEC_SYNTH_GENTLE = 0,  /* slow head sway, small swing */
    CODEC_SYNTH_VIOLENT,     /* fast, large head motion and swing */
    CODEC_SYNTH_TELEPORT     /* gentle, but the head jumps far every second */
} codec_synth_style;

static inline void codec_synth_rot(double *v, const double *axis, double ang)
{
    double c = cos(ang), s = sin(ang), d = axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2];
    double cx = axis[1] * v[2] - axis[2] * v[1], cy = axis[2] * v[0] - axis[0] * v[2],
           cz = axis[0] * v[1] - axis[1] * v[0];
    double r[3] = { v[0] * c + cx * s + axis[0] * d * (1 - c), v[1] * c + cy * s + axis[1] * d * (1 - c),
                    v[2] * c + cz * s + axis[2] * d * (1 - c) };
    v[0] = r[0];
    v[1] = r[1];
    v[2] = r[2];
}

/* The rigid head motion at time t: world = R_y(yaw) R_x(pitch) local + head. */
static inline void codec_synth_head(double t, codec_synth_style style, double *yaw, double *pitch, double head[3])
{
    double amp = 1.0, freq = 1.0, jump[3] = { 0, 0, 0 };
    if (style == CODEC_SYNTH_VIOLENT) {
        amp = 4.0;
        freq = 5.0;
    }
    if (style == CODEC_SYNTH_TELEPORT) {
        double k = floor(t);
        jump[0] = 1.5 * sin(k * 2.1);
        jump[1] = 0.7 * cos(k * 1.3);
        jump[2] = 0.9 * sin(k * 0.7 + 1.0);
    }
    *yaw = 0.4 * amp * sin(0.9 * freq * t);
    *pitch = 0.15 * amp * sin(1.3 * freq * t);
    head[0] = 0.05 * amp * sin(0.7 * freq * t) + jump[0];
    head[1] = 1.6 + 0.03 * amp * sin(1.1 * freq * t) + jump[1];
    head[2] = jump[2];
}

/* The snapshot a frame of the animation at time t and step carries: the head as a position and
 * the unit quaternion of R_y(yaw) R_x(pitch). */
static inline codec_sim_info codec_synth_sim(double t, uint64_t step, codec_synth_style style)
{
    double yaw, pitch, head[3];
    codec_synth_head(t, style, &yaw, &pitch, head);
    double cy = cos(0.5 * yaw), sy = sin(0.5 * yaw), cp = cos(0.5 * pitch), sp = sin(0.5 * pitch);
    return (codec_sim_info){ .sim_time = t, .sim_step = step,
                             .head_pos = { (float)head[0], (float)head[1], (float)head[2] },
                             .head_rot = { (float)(cy * sp), (float)(sy * cp), (float)(-sy * sp), (float)(cy * cp) } };
}

/* Fills xyz (3 * nstrands * nverts floats, strand-major, vertex 0 = root) with the pose at
 * time t (seconds). Deterministic for given arguments. */
static inline void codec_synth_frame(uint32_t nstrands, uint32_t nverts, double t, codec_synth_style style,
                                     float *xyz)
{
    const double pi = 3.14159265358979323846, golden = pi * (3.0 - sqrt(5.0)), radius = 0.1;
    const double amp = style == CODEC_SYNTH_VIOLENT ? 4.0 : 1.0, freq = style == CODEC_SYNTH_VIOLENT ? 5.0 : 1.0;
    const double yaxis[3] = { 0, 1, 0 }, xaxis[3] = { 1, 0, 0 };
    double yaw, pitch, head[3];
    codec_synth_head(t, style, &yaw, &pitch, head);
    for (uint32_t i = 0; i < nstrands; i++) {
        double yv = 1.0 - ((double)i + 0.5) / (double)nstrands * 0.9, rr = sqrt(1.0 - yv * yv);
        double phi = (double)i * golden;
        double n[3] = { rr * cos(phi), yv, rr * sin(phi) };
        double tangent[3] = { -sin(phi), 0.0, cos(phi) };
        double h = sin((double)i * 12.9898) * 43758.5453;
        double len = 0.2 + 0.1 * (h - floor(h)), seg = len / (double)(nverts - 1);
        double fall = acos(-yv) * 0.9, phase = (double)i * 0.37;
        double p[3] = { radius * n[0], radius * n[1], radius * n[2] };
        for (uint32_t k = 0; k < nverts; k++) {
            if (k > 0) {
                double u = (double)k / (double)(nverts - 1);
                double th = fall * u * u * (3.0 - 2.0 * u) +
                            0.3 * amp * u * sin(2.0 * freq * t + phase - 0.3 * (double)k);
                double d[3] = { n[0], n[1], n[2] };
                codec_synth_rot(d, tangent, th);
                codec_synth_rot(d, yaxis, 0.2 * amp * u * sin(1.7 * freq * t + 1.7 * phase));
                for (int a = 0; a < 3; a++) p[a] += seg * d[a];
            }
            double w[3] = { p[0], p[1], p[2] };
            codec_synth_rot(w, xaxis, pitch);
            codec_synth_rot(w, yaxis, yaw);
            float *o = xyz + 3u * ((size_t)i * nverts + k);
            for (int a = 0; a < 3; a++) o[a] = (float)(w[a] + head[a]);
        }
    }
}

#endif
