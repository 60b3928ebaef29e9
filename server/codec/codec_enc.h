/* codec: the encoder's per-strand kernels (quantise, motion-compensate, choose the prediction,
 * tokenise) on strands laid out as three rows x, y, z; each kernel has a portable path and,
 * when built with __AVX2__, a vector path that gives exactly the same results. */
#ifndef CODEC_CODEC_ENC_H
#define CODEC_CODEC_ENC_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "codec_rans.h"

/* A strand in the encoder is three rows (x, y, z) of nvp int32 lanes, nvp = nverts rounded up
 * to CODEC_LANES; per-strand scratch rows also have CODEC_ROW_PAD lanes in front (kernels read
 * vertices v - 1 .. v - 3). Lanes past nverts hold zeros or values of earlier strands. */
#define CODEC_LANES 8u
#define CODEC_ROW_PAD 8u

static inline uint32_t codec_lanes_round(uint32_t nverts)
{
    return (nverts + CODEC_LANES - 1u) / CODEC_LANES * CODEC_LANES;
}

/* Quantisation constants of a stream (codec_quant_setup). */
typedef struct codec_quant {
    double step, inv;
    float bound;
    float xlim; /* |x| up to this takes the fast path */
} codec_quant;

void codec_quant_setup(codec_quant *qz, float bound);

/* The fast path for one strand: src holds nv vertices (xyz), rows[a][v] gets the lattice
 * coordinate of vertex v, axis a, rounded half up. Returns false when a coordinate is out of
 * the fast range or its float32 reconstruction misses the bound; the caller then quantises the
 * strand with codec_quant_careful instead (the rows hold garbage). */
bool codec_quant_fast(const codec_quant *qz, const float *src, uint32_t nv, int32_t *const rows[3], bool portable);

/* The careful path for one strand: per coordinate the nearest lattice point (half to even)
 * whose float32 reconstruction is within the bound, or its neighbour. Fails with CORE_EINVAL
 * on the first coordinate that is not finite, out of range or unreachable (strand names the
 * strand in the message). */
core_status codec_quant_careful(const codec_quant *qz, const float *src, uint32_t nv, int32_t *const rows[3],
                                uint32_t strand, core_err *err);

/* The root q[0..3) of a strand as either path gives it; false when the two may differ or the
 * root fails (then quantise the whole strand to learn it). */
bool codec_quant_root(const codec_quant *qz, const float *src, int32_t q[3]);

/* out rows = the rigid motion m applied to the rows k, lanes 0..n-1 (as codec_motion_apply). */
void codec_motion_apply_rows(const float m[12], const int32_t *const k[3], int32_t *const out[3], uint32_t n,
                             bool portable);

/* Candidate residuals of vertices v >= 2, from this strand's rows P and a reference X (the
 * moved keyframe strand in deltas, the previous strand or zeros in keyframes); dP, dX are
 * segments (P[v] - P[v-1]):
 *   kind 0: dP - dX                          (delta mode 0, keyframe mode 1)
 *   kind 1: (dP - dX)[v] - (dP - dX)[v-1]    (delta mode 1)
 *   kind 2: dP[v] - dP[v-1]                  (delta mode 2, keyframe mode 0)
 *   kind 3: dP[v] - half(dP[v-1] + dP[v-2]), at v = 2 as kind 2 (delta mode 3, keyframe mode 2)
 * Vertex 1 is dP - dX under every mode. */
#define CODEC_KINDS 4u

/* Residual of kind k at vertex v >= 2 of one row (p = P row, x = X row). */
static inline int32_t codec_kind_one(uint32_t kind, const int32_t *p, const int32_t *x, uint32_t v)
{
    int32_t dp0 = p[v] - p[v - 1], dp1 = p[v - 1] - p[v - 2];
    switch (kind) {
    case 0:
        return dp0 - (x[v] - x[v - 1]);
    case 1:
        return dp0 - (x[v] - x[v - 1]) - (dp1 - (x[v - 1] - x[v - 2]));
    case 2:
        return dp0 - dp1;
    default:
        return v == 2u ? dp0 - dp1 : dp0 - codec_half(dp1 + (p[v - 2] - p[v - 3]));
    }
}

/* cost[k] = the sum over v >= 2 and the axes of floor(log2(2 |r| + 1)) (float32 exponent of
 * 2 |r| + 1) of kind k; kind 1 only when with_kind1. Rows need CODEC_ROW_PAD lanes in front. */
void codec_kind_costs(const int32_t *const P[3], const int32_t *const X[3], uint32_t nv, bool with_kind1,
                      uint32_t cost[CODEC_KINDS], bool portable);

/* Symbols, histogram and raw bits of one frame, in coding order. */
typedef struct codec_emitter {
    uint16_t *syms;    /* table * CODEC_NSYM + symbol */
    size_t nsyms;
    uint32_t *counts;  /* CODEC_HIST_COPIES histograms of CODEC_NTABLES * CODEC_NSYM, summed later */
    uint8_t *bits;     /* raw bit stream: written 8 bytes at a time, needs 8 bytes of slack */
    uint64_t acc;      /* bits not yet whole bytes, n of them */
    uint32_t n;
} codec_emitter;

#define CODEC_HIST_COPIES 4u
#define CODEC_HIST_SIZE (CODEC_NTABLES * CODEC_NSYM)

/* Per-strand scratch of codec_emit_strand, for nvp vertices. */
typedef struct codec_tok_scratch {
    int32_t *R[3];                  /* residual rows */
    uint16_t *idx;                  /* nvp symbols */
    uint8_t *esc;                   /* nvp / 8 masks of escaped vertices */
    uint64_t *pair_bits, *pair_nb;  /* nvp / 2 each */
} codec_tok_scratch;

/* Emits a symbol of table t. */
static inline void codec_emit_symbol(codec_emitter *e, uint32_t t, uint32_t sym)
{
    uint32_t idx = t * CODEC_NSYM + sym;
    e->syms[e->nsyms++] = (uint16_t)idx;
    e->counts[idx]++;
}

/* Stores v at p[0..8) little-endian. */
static inline void codec_put_le64(uint8_t *p, uint64_t v)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    memcpy(p, &v, 8);
#else
    for (int k = 0; k < 8; k++) p[k] = (uint8_t)(v >> (8 * k));
#endif
}

/* Appends the nb (<= 32) low bits of v to the raw bit stream. */
static inline void codec_emit_bits(codec_emitter *e, uint64_t v, uint32_t nb)
{
    uint64_t acc = e->acc | v << e->n;
    uint32_t n = e->n + nb;
    uint8_t *p = e->bits;
    codec_put_le64(p, acc);
    e->bits = p + (n >> 3);
    e->acc = acc >> (n & ~7u);
    e->n = n & 7u;
}

/* Emits the vertex symbols and raw bits of one strand coded with residual kind `kind` of P
 * against X (vertex 1 as dP - dX; the root's residuals given): vertex 0 in the root table,
 * vertex 1 in the first segment table, later ones in the body table chosen by the previous
 * vertex. */
void codec_emit_strand(codec_emitter *e, uint32_t kind, const int32_t *const P[3], const int32_t *const X[3],
                       const int32_t root[3], uint32_t nv, const codec_tok_scratch *s, bool portable);

/* Pads the raw bit stream to a whole byte; returns its end. */
uint8_t *codec_emit_finish(codec_emitter *e);

#endif
