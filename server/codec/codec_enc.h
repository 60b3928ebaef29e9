/* codec: the encoder's kernels on groups of 8 strands held side by side (one strand per vector
 * lane; the same lanes as the format's rANS states): quantise, motion-compensate, estimate the
 * mode costs, tokenise, emit; each kernel has a portable path
 * and, when built with __AVX2__, a vector path that gives exactly the same results. */
#ifndef CODEC_CODEC_ENC_H
#define CODEC_CODEC_ENC_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "codec_rans.h"

/* A group holds CODEC_GROUP strands; its lattice coordinates are laid out [vertex][axis][lane]
 * (CODEC_GSTRIDE int32 per vertex), so one vector load gives one axis of one vertex of all
 * strands. The last group of a frame repeats its last strand in the unused lanes. */
#define CODEC_GROUP 8u
#define CODEC_GSTRIDE (3u * CODEC_GROUP)
#define CODEC_GAT(v, a, l) ((size_t)(v) * CODEC_GSTRIDE + (size_t)(a) * CODEC_GROUP + (size_t)(l))

/* Quantisation constants of a stream (codec_quant_setup). */
typedef struct codec_quant {
    double step, inv;
    float bound;
    float xlim; /* |x| up to this takes the fast path */
    float xsafe; /* |x| up to this needs no float32 check (codec_quant_setup proves it) */
} codec_quant;

void codec_quant_setup(codec_quant *qz, float bound);

/* The fast path for a group: src[l] holds the nv vertices (xyz) of lane l's strand, P gets the
 * lattice coordinates rounded half up (truncation of x / step + 2^27 + 1/2 in binary64). Returns the mask of lanes where a coordinate is out of
 * the fast range or its float32 reconstruction misses the bound (those lanes hold garbage; the
 * caller quantises them with codec_quant_careful). next: NULL, or the 8 strands to prefetch
 * meanwhile (the next group's). */
uint32_t codec_quant_group(const codec_quant *qz, const float *const src[CODEC_GROUP], uint32_t nv, int32_t *P,
                           const float *const *next, bool portable);

/* The careful path for lane l: per coordinate the nearest lattice point (half to even) whose
 * float32 reconstruction is within the bound, or its neighbour. Fails with CORE_EINVAL on the
 * first coordinate that is not finite, out of range or unreachable (strand names the strand in
 * the message). */
core_status codec_quant_careful(const codec_quant *qz, const float *src, uint32_t nv, int32_t *P, uint32_t l,
                                uint32_t strand, core_err *err);

/* The root q[0..3) of a strand as either path gives it; false when the two may differ or the
 * root fails (then quantise the whole strand to learn it). */
bool codec_quant_root(const codec_quant *qz, const float *src, int32_t q[3]);

/* A keyframe group as deltas use it (its "reference"), in int32 units: the roots [axis][lane],
 * then per vertex v >= 1 the clamped segments d = clamp15(K[v] - K[v-1]) of proto/CODEC.md
 * packed for 16-bit multiply-adds: [lane] d_x | d_y << 16, then [lane] d_z | 1 << 16. */
#define CODEC_KREF_SIZE(nv) (16u * (size_t)(nv) + 8u)

/* The reference kref (CODEC_KREF_SIZE(nv) int32) of the keyframe group K (nv vertices). */
void codec_kref_group(const int32_t *K, uint32_t nv, int32_t *kref, bool portable);

/* The delta reference of the keyframe group kref (nv vertices) under motion m: X[0] = the moved
 * roots, X[v] = X[v-1] + S[v] (the moved segments), so that X's segments are the S of
 * proto/CODEC.md. more: another group's reference follows kref (prefetched meanwhile). */
void codec_motion_group(const codec_motion *m, const int32_t *kref, int32_t *X, uint32_t nv, bool more, bool portable);

/* The modes the encoder tries, one candidate residual each for vertex v >= 2 of a strand P
 * against a reference X (the moved keyframe in deltas, the previous strand or zeros in
 * keyframes); dP, dX are segments (P[v] - P[v-1]):
 *   delta mode 0: dP - dX
 *   delta mode 1: (dP - dX)[v] - (dP - dX)[v-1]
 *   delta mode 2, keyframe mode 0: dP[v] - dP[v-1]
 *   keyframe mode 1: dP - dX
 *   keyframe mode 2: dP[v] - half(dP[v-1] + dP[v-2]), at v = 2 as mode 0
 * Vertex 1 is dP - dX under every mode. Delta mode 3 (smooth linear) is valid in a frame but
 * not tried: on recorded simulation frames it never made a stream smaller. */
#define CODEC_CANDS 3u

/* Candidate residuals of a group, [vertex][axis][mode][lane] (CODEC_CSTRIDE int32 per vertex);
 * vertex 1 holds dP - dX under every mode, vertex 0 is unused. */
#define CODEC_CSTRIDE (3u * CODEC_CANDS * CODEC_GROUP)
#define CODEC_CAT(v, a, m, l) \
    ((size_t)(v) * CODEC_CSTRIDE + ((size_t)(a) * CODEC_CANDS + (size_t)(m)) * CODEC_GROUP + (size_t)(l))

/* Fills cand (nv vertices) for a keyframe (key) or a delta and cost[m * CODEC_GROUP + l] = the
 * sum over v >= 2 and the axes of the bits of |r| (0 for r = 0, else floor(log2 |r|) + 1, from
 * the float32 exponent of |r|) of mode m's residuals r in lane l. */
void codec_costs_group(const int32_t *P, const int32_t *X, uint32_t nv, bool key, uint32_t cost[CODEC_CANDS * CODEC_GROUP],
                       int32_t *cand, bool portable);

/* Per-group token scratch (codec_tokens_group fills it, codec_emit_group reads it). */
typedef struct codec_tokens {
    const int32_t *cand;   /* the group's candidates (codec_costs_group) */
    const uint32_t *mode;  /* [lane]: the mode (its candidate) */
    const int32_t *root;   /* [axis][lane]: the root residuals */
    uint16_t *sym;   /* [vertex][lane]: table * CODEC_NSYM + classes (may be where
                        codec_emit_group puts them, after the group's modes: then not copied) */
    uint64_t *pbits; /* [vertex][4]: raw bits of lanes 0-3 and 4-7, then their lengths (at most
                        60 bits; valid where no lane of the vertex escapes) */
    uint8_t *esc;    /* [vertex]: the lanes whose vertex escapes */
    uint32_t *xbits; /* [vertex][axis][3][lane]: each axis's raw bits, escapes included (bits
                        0-31, bits 32 and up), then their count (valid where a lane of the vertex
                        escapes, or everywhere when asked for) */
} codec_tokens;

/* uint32 per vertex of codec_tokens.xbits. */
#define CODEC_XSTRIDE (3u * 3u * CODEC_GROUP)

/* Tokens of every lane of the group t describes (nv vertices); xbits of every vertex when all
 * (a partial group, which codec_emit_group writes lane by lane), else of those that escape.
 * Returns the lanes with an escape anywhere. */
uint32_t codec_tokens_group(const codec_tokens *t, uint32_t nv, bool all, bool portable);

/* Symbols, histogram and raw bits of one frame, in coding order. */
typedef struct codec_emitter {
    uint16_t *syms;    /* table * CODEC_NSYM + symbol */
    size_t nsyms;
    uint32_t *counts;  /* CODEC_HIST_COPIES histograms of CODEC_HIST_SIZE, summed later */
    uint8_t *bits;     /* raw bit stream: written 8 bytes at a time, needs 8 bytes of slack */
    uint64_t acc;      /* bits not yet whole bytes, n of them */
    uint32_t n;
} codec_emitter;

#define CODEC_HIST_COPIES 4u
#define CODEC_HIST_SIZE (CODEC_NTABLES * CODEC_NSYM)

/* Stores v at p[0..8) little-endian. */
static inline void codec_put_le64(uint8_t *p, uint64_t v)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    memcpy(p, &v, 8);
#else
    for (int k = 0; k < 8; k++) p[k] = (uint8_t)(v >> (8 * k));
#endif
}

/* Appends the nb (<= 56) low bits of v to the raw bit stream. */
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

/* Emits a symbol of table t. */
static inline void codec_emit_symbol(codec_emitter *e, uint32_t t, uint32_t sym)
{
    uint32_t idx = t * CODEC_NSYM + sym;
    e->syms[e->nsyms++] = (uint16_t)idx;
    e->counts[idx]++;
}

/* Emits the symbols (modes, then vertex by vertex across the lanes) and raw bits of lanes
 * 0..n-1 of a tokenised group; esc is codec_tokens_group's result. */
void codec_emit_group(codec_emitter *e, const codec_tokens *t, const uint32_t mode[CODEC_GROUP], uint32_t n,
                      uint32_t nv, uint32_t esc);

/* Pads the raw bit stream to a whole byte; returns its end. */
uint8_t *codec_emit_finish(codec_emitter *e);

#endif
