/* codec: two-state byte-wise rANS with per-frame static tables, plus the raw bit stream. */
#ifndef CODEC_CODEC_RANS_H
#define CODEC_CODEC_RANS_H

#include <stdint.h>

#include "codec_internal.h"

/* One symbol of one table, prepared for division-free encoding. */
typedef struct codec_rans_sym {
    uint32_t x_max;     /* renormalise while the state is at or above this */
    uint32_t rcp_freq;  /* fixed-point reciprocal of freq */
    uint32_t bias;
    uint16_t cmpl_freq; /* SCALE - freq */
    uint16_t rcp_shift; /* q = x * rcp_freq >> rcp_shift = floor(x / freq) */
} codec_rans_sym;

/* Decoder side of all tables of a frame. */
typedef struct codec_rans_tables {
    uint16_t freq[CODEC_NTABLES][CODEC_NSYM];
    uint16_t start[CODEC_NTABLES][CODEC_NSYM];
    uint32_t nsym[CODEC_NTABLES];
} codec_rans_tables;

/* Scales counts[0..n) to frequencies summing to CODEC_SCALE, every used symbol at least 1.
 * Returns the used alphabet size (last nonzero + 1; 0 when all counts are zero). */
uint32_t codec_rans_normalize(const uint32_t *counts, uint32_t n, uint16_t *freq);

/* Prepares symbol (start, freq) for encoding. */
void codec_rans_sym_init(codec_rans_sym *s, uint32_t start, uint32_t freq);

/* Appends a table's description at *p (LEB128: the count of used symbols, then for each the
 * gap from the previous used symbol and its frequency); returns the new end. The caller
 * reserves 5 * (CODEC_NSYM + 1) bytes per table. */
uint8_t *codec_rans_write_table(uint8_t *p, const uint16_t *freq, uint32_t nsym);

/* Parses every table at data[*pos..len), fills tabs and the slot lookup (CODEC_NTABLES x
 * CODEC_SCALE entries; 0xffff marks an empty table). */
core_status codec_rans_read_tables(const uint8_t *data, size_t len, size_t *pos, codec_rans_tables *tabs,
                                   uint16_t *slots, core_err *err);

/* Encodes syms[0..n) (indices table * CODEC_NSYM + symbol into rs) last first, symbol i with
 * state x[i & 1] (both start at CODEC_RANS_L), writing bytes downwards ending at end; returns
 * the first byte. The buffer needs 2 * n + 2 bytes below end. */
uint8_t *codec_rans_encode(const uint16_t *syms, size_t n, const codec_rans_sym *rs, uint8_t *end, uint32_t x[2]);

#endif
