/* strandbench codec --hairmesh: one hairstyle streamed as strands and as its hair mesh. */
#ifndef BENCH_BENCH_CODEC_HAIRMESH_H
#define BENCH_BENCH_CODEC_HAIRMESH_H

#include <stdint.h>

/* The run's settings (strandbench codec's options). */
typedef struct bench_hairmesh_opts {
    const char *style;   /* straight | wavy | curly: the procedural hair mesh's style */
    uint32_t grid;       /* quads along each side of a scalp patch (0: the generator's default) */
    uint32_t nlayers;    /* its layers */
    uint32_t per_face;   /* strands traced through each face */
    uint32_t nverts;     /* vertices per strand */
    double seconds, fps; /* the animation's length and frame rate */
    int json;            /* one JSON row per source and bound instead of the table */
    int sim;             /* frames of the hair-mesh solver (one per step, at its dt) instead of
                            the animation */
} bench_hairmesh_opts;

/* Encodes and decodes the animation at three bounds as strands and as the hair mesh, prints the
 * bytes per frame and the largest error of each; returns the exit code. */
int bench_codec_hairmesh(const bench_hairmesh_opts *o);

#endif
