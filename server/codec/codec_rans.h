/* codec: eight-state rANS with 16-bit renormalisation and per-frame static tables. */
#ifndef CODEC_CODEC_RANS_H
#define CODEC_CODEC_RANS_H

#include <stdbool.h>
#include <stdint.h>

#include "codec_internal.h"

/* One symbol of one table, prepared for division-free encoding. */
typedef struct codec_rans_sym {
    uint64_t rcp;       /* floor(x / freq) = x * rcp >> 44 for every state x < freq * 2^20 */
    uint32_t freq;      /* renormalise when x >> 20 >= freq */
    uint32_t bias;      /* start */
    uint32_t cmpl_freq; /* SCALE - freq */
} codec_rans_sym;

/* Scales counts[0..n) to frequencies summing to CODEC_SCALE, every used symbol at least 1.
 * Returns the used alphabet size (last nonzero + 1; 0 when all counts are zero). */
uint32_t codec_rans_normalize(const uint32_t *counts, uint32_t n, uint16_t *freq);

/* The same symbol for the vector path, as binary64 (every value exact but rcp, which is 1 / freq
 * correctly rounded): one 32-byte load per symbol, four of them transposed into four vectors. */
typedef struct codec_rans_vsym {
    double freq20; /* freq 2^20: renormalise when x >= this */
    double start;
    double cmpl;   /* SCALE - freq */
    double rcp;    /* 1 / freq */
} codec_rans_vsym;

/* Prepares symbol (start, freq) for encoding, for the scalar (s) and the vector (vs) path. */
void codec_rans_sym_init(codec_rans_sym *s, codec_rans_vsym *vs, uint32_t start, uint32_t freq);

/* Appends a table's description at *p (LEB128: the count of used symbols, then for each the
 * gap from the previous used symbol and its frequency); returns the new end. The caller
 * reserves 5 * (CODEC_NSYM + 1) bytes per table. */
uint8_t *codec_rans_write_table(uint8_t *p, const uint16_t *freq, uint32_t nsym);

/* Encodes the symbols of a frame (indices table * CODEC_NSYM + symbol into rs) last first:
 * syms[0..nfull) have lane i % CODEC_LANES, the ntail after them lane (i - nfull) % tail_lanes
 * (nfull a multiple of CODEC_LANES; tail_lanes >= 1 when ntail > 0). The states start at
 * CODEC_RANS_L; 16-bit words go downwards ending at end. Returns the first word; x gets the
 * final states. The buffer needs 2 * (nfull + ntail) + 16 bytes below end. The AVX2 path (unless
 * portable) gives the same words and states; it reads vs (codec_rans_sym_init) instead of rs. */
uint8_t *codec_rans_encode(const uint16_t *syms, size_t nfull, size_t ntail, uint32_t tail_lanes,
                           const codec_rans_sym *rs, const codec_rans_vsym *vs, uint8_t *end,
                           uint32_t x[CODEC_LANES], bool portable);

#endif
