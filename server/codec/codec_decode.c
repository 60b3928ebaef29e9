/* codec: the decoder (validate, parse tables, rANS-decode, predict, dequantise). */
#include <stdlib.h>
#include <string.h>

#include "codec_rans.h"

#define BAD UINT32_MAX

/* Per vertex symbol (c0 + 7 c1 + 49 c2): the classes in bits 0-3, 4-7, 8-11, their sum (the raw
 * bits when no axis escapes) in 12-15 (0 when one does), the next vertex's body table in 16-19,
 * bit 20 when an axis escapes. */
#define SYM_E(s)                                                                                         \
    ((uint32_t)(s) % 7u | (uint32_t)(s) / 7u % 7u << 4 | (uint32_t)(s) / 49u << 8 |                      \
     (SYM_MAX3(s) < 6u ? (uint32_t)(s) % 7u + (uint32_t)(s) / 7u % 7u + (uint32_t)(s) / 49u : 0u) << 12 |    \
     (CODEC_T_BODY + (SYM_MAX3(s) < 5u ? SYM_MAX3(s) : 5u)) << 16 | (uint32_t)(SYM_MAX3(s) == 6u) << 20)
#define SYM_MAX2(a, b) ((a) > (b) ? (a) : (b))
#define SYM_MAX3(s) SYM_MAX2(SYM_MAX2((uint32_t)(s) % 7u, (uint32_t)(s) / 7u % 7u), (uint32_t)(s) / 49u)
#define SYM_R7(b) SYM_E(b), SYM_E(b + 1), SYM_E(b + 2), SYM_E(b + 3), SYM_E(b + 4), SYM_E(b + 5), SYM_E(b + 6)
#define SYM_R49(b) SYM_R7(b), SYM_R7(b + 7), SYM_R7(b + 14), SYM_R7(b + 21), SYM_R7(b + 28), SYM_R7(b + 35), SYM_R7(b + 42)
static const uint32_t SYMTAB[CODEC_NSYM] = { SYM_R49(0), SYM_R49(49), SYM_R49(98), SYM_R49(147),
                                             SYM_R49(196), SYM_R49(245), SYM_R49(294) };

/* Entropy decoding state of one frame. */
typedef struct reader {
    const codec_rans_tables *tabs;
    const uint16_t *slots;
    const uint8_t *data;   /* rANS bytes [pos, end) */
    size_t pos, end;
    uint32_t x[2];
    uint32_t which;        /* state used by the next symbol */
    const uint8_t *bdata;  /* raw bits [bpos, bend) */
    size_t bpos, bend;
    uint64_t acc;
    uint32_t nacc;
} reader;

/* Next symbol of table t, or BAD (empty table, stream overrun). */
static inline __attribute__((always_inline)) uint32_t get_sym(reader *r, uint32_t t)
{
    uint32_t x = r->x[r->which];
    uint32_t slot = x & (CODEC_SCALE - 1u);
    uint32_t s = r->slots[(size_t)t * CODEC_SCALE + slot];
    if (s == 0xffffu) return BAD;
    x = r->tabs->freq[t][s] * (x >> CODEC_SCALE_BITS) + slot - r->tabs->start[t][s];
    while (x < CODEC_RANS_L) {
        if (r->pos >= r->end) return BAD;
        x = (x << 8) | r->data[r->pos++];
    }
    r->x[r->which] = x;
    r->which ^= 1u;
    return s;
}

static inline __attribute__((always_inline)) void refill(reader *r)
{
    if (r->nacc > 32) return;
    if (r->bpos <= r->bend && r->bend - r->bpos >= 4) {
        r->acc |= (uint64_t)codec_get_u32(r->bdata + r->bpos) << r->nacc;
        r->bpos += 4;
        r->nacc += 32;
        return;
    }
    while (r->nacc <= 56) { /* the tail: zeros past the end, counted for the final check */
        uint64_t b = r->bpos < r->bend ? r->bdata[r->bpos] : 0u;
        r->bpos++;
        r->acc |= b << r->nacc;
        r->nacc += 8;
    }
}

/* Next nb (<= 32) raw bits, least significant first. */
static inline __attribute__((always_inline)) uint32_t get_bits(reader *r, uint32_t nb)
{
    refill(r);
    uint32_t v = (uint32_t)(r->acc & ((1ull << nb) - 1u));
    r->acc >>= nb;
    r->nacc -= nb;
    return v;
}

/* Residual of class c (0..5) from its c-bit field f (sign in bit 0). */
static inline int32_t field_residual(uint32_t c, uint32_t f)
{
    uint32_t m = ((1u << c) >> 1) | (f >> 1), sign = f & 1u;
    return (int32_t)((m ^ (0u - sign)) + sign);
}

/* One escaped axis: e = 5 + a symbol of the escape table, then the sign and e bits below the
 * leading one (raw). */
static inline __attribute__((always_inline)) bool escape_residual(reader *r, int32_t *res)
{
    uint32_t k = get_sym(r, CODEC_T_ESC);
    if (k >= CODEC_NESC) return false; /* also BAD */
    uint32_t ex = k + 5u, sign = get_bits(r, 1);
    uint32_t m = (1u << ex) | get_bits(r, ex);
    *res = (int32_t)((m ^ (0u - sign)) + sign);
    return true;
}

/* Decodes one vertex's residuals coded with table t into res; returns the next vertex's
 * table, or BAD. */
static inline __attribute__((always_inline)) uint32_t get_vertex(reader *r, uint32_t t, int32_t *res)
{
    uint32_t s = get_sym(r, t);
    if (s == BAD) return BAD;
    const uint32_t e = SYMTAB[s], c0 = e & 15u, c1 = e >> 4 & 15u, c2 = e >> 8 & 15u;
    if (!(e >> 20)) {
        uint32_t b = get_bits(r, e >> 12 & 15u);
        res[0] = field_residual(c0, b & ((1u << c0) - 1u));
        b >>= c0;
        res[1] = field_residual(c1, b & ((1u << c1) - 1u));
        res[2] = field_residual(c2, b >> c1);
    } else {
        const uint32_t c[3] = { c0, c1, c2 };
        for (uint32_t a = 0; a < 3; a++) {
            if (c[a] < CODEC_ESCAPE) res[a] = field_residual(c[a], get_bits(r, c[a]));
            else if (!escape_residual(r, &res[a])) return BAD;
        }
    }
    return e >> 16 & 15u;
}

static inline bool in_range(int32_t q)
{
    return (uint32_t)(q + (CODEC_MAX_QUANT - 1)) < (uint32_t)(2 * CODEC_MAX_QUANT - 1);
}

/* Rebuilds vertices 1..nv-1 of a strand from residuals R: P[i] = prediction + R[i], one flat
 * loop per mode (the predictions of codec_predict). Returns false on an out-of-range value. */
static bool reconstruct(bool key, uint32_t mode, int32_t *restrict P, const int32_t *restrict K,
                        const int32_t *restrict N, uint32_t nv, const int32_t *restrict R)
{
    const size_t n = (size_t)nv * 3u;
    bool ok = true;
    for (uint32_t a = 0; a < 3; a++) {
        P[3 + a] = codec_predict(key, mode, P, K, N, 1, a) + R[3 + a];
        ok &= in_range(P[3 + a]);
    }
    if (!ok) return false;
    size_t i = 6;
#define REBUILD(expr)                        \
    for (; i < n; i++) {                     \
        int32_t q = (expr) + R[i];           \
        if (!in_range(q)) return false;      \
        P[i] = q;                            \
    }
    if (key) {
        if (mode == 1u && N) {
            REBUILD(P[i - 3] + N[i] - N[i - 3])
        } else if (mode == 2u) {
            for (; i < n && i < 9; i++) {
                int32_t q = 2 * P[i - 3] - P[i - 6] + R[i];
                if (!in_range(q)) return false;
                P[i] = q;
            }
            REBUILD(codec_smooth(P, (uint32_t)i))
        } else {
            REBUILD(2 * P[i - 3] - P[i - 6])
        }
    } else if (mode == 1u) {
        REBUILD(P[i - 3] + K[i] - K[i - 3] + (P[i - 3] - K[i - 3]) - (P[i - 6] - K[i - 6]))
    } else if (mode == 2u) {
        REBUILD(2 * P[i - 3] - P[i - 6])
    } else if (mode == 3u) {
        for (; i < n && i < 9; i++) {
            int32_t q = 2 * P[i - 3] - P[i - 6] + R[i];
            if (!in_range(q)) return false;
            P[i] = q;
        }
        REBUILD(codec_smooth(P, (uint32_t)i))
    } else {
        REBUILD(P[i - 3] + K[i] - K[i - 3])
    }
#undef REBUILD
    return true;
}

void codec_decoder_init(codec_decoder *dec)
{
    if (dec) memset(dec, 0, sizeof *dec);
}

void codec_decoder_free(codec_decoder *dec)
{
    if (!dec) return;
    free(dec->key_q);
    free(dec->cur_q);
    free(dec->key_m);
    free(dec->slots);
    free(dec->res);
    memset(dec, 0, sizeof *dec);
}

static core_status reserve(codec_decoder *dec, size_t nq, uint32_t nverts, core_err *err)
{
    if (!dec->slots) {
        dec->slots = malloc((size_t)CODEC_NTABLES * CODEC_SCALE * sizeof *dec->slots);
        if (!dec->slots) return core_fail(err, CORE_ENOMEM, "codec: out of memory for decoder tables");
    }
    if (dec->res_cap < nverts) {
        int32_t *r = realloc(dec->res, (size_t)nverts * 3u * sizeof *r);
        if (!r) return core_fail(err, CORE_ENOMEM, "codec: out of memory for residuals");
        dec->res = r;
        dec->res_cap = nverts;
    }
    if (dec->cap >= nq) return CORE_OK;
    int32_t *k = realloc(dec->key_q, nq * sizeof *k);
    if (!k) return core_fail(err, CORE_ENOMEM, "codec: out of memory for %zu coordinates", nq);
    dec->key_q = k;
    int32_t *c = realloc(dec->cur_q, nq * sizeof *c);
    if (!c) return core_fail(err, CORE_ENOMEM, "codec: out of memory for %zu coordinates", nq);
    dec->cur_q = c;
    int32_t *m = realloc(dec->key_m, nq * sizeof *m);
    if (!m) return core_fail(err, CORE_ENOMEM, "codec: out of memory for %zu coordinates", nq);
    dec->key_m = m;
    dec->cap = nq;
    return CORE_OK;
}

/* Decodes every strand of the frame into dec->cur_q: first the strand's symbols and raw bits
 * into residuals, then the predictions. The reader works on a local copy (kept in registers),
 * written back at the end. */
static core_status decode_strands(codec_decoder *dec, const codec_frame_info *h, reader *rd, core_err *err)
{
    reader rl = *rd, *r = &rl;
    const bool key = h->keyframe;
    const uint32_t nv = h->nverts, nmodes = key ? CODEC_KEY_MODES : CODEC_DELTA_MODES;
    const size_t per = (size_t)nv * 3u;
    int32_t *R = dec->res;
    for (uint32_t j = 0; j < h->nstrands_sent; j++) {
        int32_t *P = dec->cur_q + (size_t)j * per;
        const int32_t *K = key ? NULL : dec->key_m + (size_t)j * per;
        const int32_t *N = j ? P - per : NULL;
        const int32_t *KN = (j && !key) ? K - per : NULL;
        uint32_t mode = get_sym(r, CODEC_T_MODE);
        if (mode == BAD || mode >= nmodes) goto bad_stream;
        uint32_t table = get_vertex(r, CODEC_T_ROOT, R);
        if (table == BAD) goto bad_stream;
        table = CODEC_T_FIRST;
        for (uint32_t v = 1; v < nv && table != BAD; v++) table = get_vertex(r, table, R + 3u * v);
        if (table == BAD) goto bad_stream;
        for (uint32_t a = 0; a < 3; a++) {
            P[a] = codec_predict_root(key, K, N, KN, a) + R[a];
            if (!in_range(P[a])) goto bad_value;
        }
        if (!reconstruct(key, mode, P, K, N, nv, R)) goto bad_value;
    }
    *rd = rl;
    return CORE_OK;
bad_stream:
    return core_fail(err, CORE_EFORMAT, "codec: corrupt entropy-coded data (invalid symbol or stream overrun)");
bad_value:
    return core_fail(err, CORE_EFORMAT, "codec: corrupt frame (decoded coordinate out of range)");
}

core_status codec_decode(codec_decoder *dec, const uint8_t *data, size_t len, float *xyz_out,
                         size_t out_floats, codec_frame_info *info, core_err *err)
{
    if (!dec || !xyz_out) return core_fail(err, CORE_EINVAL, "codec: NULL decoder or output");
    codec_frame_info h;
    core_status st = codec_peek_header(data, len, &h, err);
    if (st) return st;
    uint32_t crc = codec_get_u32(data + CODEC_OFF_CRC);
    if (codec_frame_crc(data, h.payload_len) != crc)
        return core_fail(err, CORE_EFORMAT, "codec: CRC mismatch (frame %llu corrupted)", (unsigned long long)h.seq);
    size_t nq = (size_t)h.nstrands_sent * h.nverts * 3u;
    if (out_floats < nq)
        return core_fail(err, CORE_EINVAL, "codec: output holds %zu floats, frame needs %zu", out_floats, nq);
    if (!h.keyframe) {
        if (!dec->key_valid || dec->key.seq != h.ref_seq)
            return core_fail(err, CORE_ESTATE, "codec: frame %llu needs keyframe %llu, which is not held",
                             (unsigned long long)h.seq, (unsigned long long)h.ref_seq);
        const codec_frame_info *k = &dec->key;
        if (k->nstrands_total != h.nstrands_total || k->nverts != h.nverts || k->stride != h.stride ||
            k->step != h.step)
            return core_fail(err, CORE_EFORMAT, "codec: frame %llu does not match its keyframe's layout or step",
                             (unsigned long long)h.seq);
    }
    st = reserve(dec, nq, h.nverts, err);
    if (st) return st;

    static const codec_rans_tables zero_tabs;
    codec_rans_tables tabs = zero_tabs;
    const uint8_t *pl = data + CODEC_HEADER_SIZE;
    size_t pos = 0;
    if (!h.keyframe) {
        if (h.payload_len < CODEC_MOTION_BYTES) return core_fail(err, CORE_EFORMAT, "codec: truncated payload (no motion)");
        float motion[12];
        for (int k = 0; k < 12; k++) {
            uint32_t u = codec_get_u32(pl + 4 * k);
            memcpy(&motion[k], &u, 4);
        }
        if (!codec_motion_valid(motion)) return core_fail(err, CORE_EFORMAT, "codec: invalid rigid motion");
        codec_motion_apply(motion, dec->key_q, dec->key_m, nq / 3u);
        pos = CODEC_MOTION_BYTES;
    }
    st = codec_rans_read_tables(pl, h.payload_len, &pos, &tabs, dec->slots, err);
    if (st) return st;
    if (h.payload_len - pos < 4) return core_fail(err, CORE_EFORMAT, "codec: truncated payload (no stream length)");
    uint32_t rans_len = codec_get_u32(pl + pos);
    pos += 4;
    if (rans_len < 8 || rans_len > h.payload_len - pos)
        return core_fail(err, CORE_EFORMAT, "codec: entropy stream length %u invalid for %zu payload bytes left",
                         rans_len, h.payload_len - pos);
    reader r = { .tabs = &tabs, .slots = dec->slots, .data = pl, .pos = pos + 8u, .end = pos + rans_len,
                 .which = 0, .bdata = pl, .bpos = pos + rans_len, .bend = h.payload_len };
    r.x[0] = codec_get_u32(pl + pos);
    r.x[1] = codec_get_u32(pl + pos + 4u);
    for (int k = 0; k < 2; k++)
        if (r.x[k] < CODEC_RANS_L || r.x[k] >= (CODEC_RANS_L << 8))
            return core_fail(err, CORE_EFORMAT, "codec: invalid entropy coder state");
    st = decode_strands(dec, &h, &r, err);
    if (st) return st;
    if (r.x[0] != CODEC_RANS_L || r.x[1] != CODEC_RANS_L || r.pos != r.end)
        return core_fail(err, CORE_EFORMAT, "codec: entropy stream does not end where the frame says");
    size_t bits_avail = (r.bend - (pos + rans_len)) * 8u, bits_used = (r.bpos - (pos + rans_len)) * 8u - r.nacc;
    if (bits_used > bits_avail || bits_avail - bits_used >= 8u)
        return core_fail(err, CORE_EFORMAT, "codec: raw bit stream is %zu bits, frame used %zu", bits_avail,
                         bits_used);

    for (size_t i = 0; i < nq; i++) xyz_out[i] = (float)((double)dec->cur_q[i] * h.step);
    if (h.keyframe) {
        int32_t *t = dec->key_q;
        dec->key_q = dec->cur_q;
        dec->cur_q = t;
        dec->key = h;
        dec->key_valid = true;
    }
    if (info) *info = h;
    return CORE_OK;
}
