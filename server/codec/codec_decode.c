/* codec: the decoder (validate, parse tables, rANS-decode, predict, dequantise). */
#include <stdlib.h>
#include <string.h>

#include "codec_enc.h"

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

#define BAD_ESC (UINT32_MAX - 1u)

/* Entropy decoding state of one frame. */
typedef struct reader {
    const codec_rans_tables *tabs;
    const uint16_t *slots;
    const uint8_t *data;   /* rANS words [pos, end) */
    size_t pos, end;
    uint32_t x[CODEC_LANES];
    uint32_t overrun;      /* a word was needed past the end */
    const uint8_t *bdata;  /* raw bits [bpos, bend) */
    size_t bpos, bend;
    uint64_t acc;
    uint32_t nacc;
} reader;

/* Next symbol of table t in lane l, or BAD (empty table). The renormalisation is branch-free:
 * a word past the end of the stream reads as 0 and sets r->overrun. */
static inline __attribute__((always_inline)) uint32_t get_sym(reader *r, uint32_t l, uint32_t t)
{
    uint32_t x = r->x[l];
    uint32_t slot = x & (CODEC_SCALE - 1u);
    uint32_t s = r->slots[(size_t)t * CODEC_SCALE + slot];
    if (s == 0xffffu) return BAD;
    x = r->tabs->freq[t][s] * (x >> CODEC_SCALE_BITS) + slot - r->tabs->start[t][s];
    const uint32_t need = x < CODEC_RANS_L, have = r->end - r->pos >= 2u;
    const uint32_t w = codec_get_u16(r->data + (have ? r->pos : r->end - 2u));
    r->overrun |= need & !have;
    r->pos += 2u * (need & have);
    r->x[l] = need ? (x << 16) | w : x;
    return s;
}

static inline __attribute__((always_inline)) void refill(reader *r)
{
    if (r->bpos <= r->bend && r->bend - r->bpos >= 8) {
        /* branch-free: 8 bytes ORed in, the whole bytes that fit counted (the bits above them
         * are the next bytes, ORed in again identically by the next refill) */
        r->acc |= codec_get_u64(r->bdata + r->bpos) << r->nacc;
        r->bpos += (63u - r->nacc) >> 3;
        r->nacc |= 56u;
        return;
    }
    if (r->nacc > 32) return;
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

/* One escaped axis: 5 raw bits of e - 5, the sign, then the e bits below the leading one. */
static inline __attribute__((always_inline)) bool escape_residual(reader *r, int32_t *res)
{
    uint32_t k = get_bits(r, CODEC_ESC_BITS);
    if (k > CODEC_ESC_MAX) return false;
    uint32_t ex = k + 5u, sign = get_bits(r, 1);
    uint32_t m = (1u << ex) | get_bits(r, ex);
    *res = (int32_t)((m ^ (0u - sign)) + sign);
    return true;
}

/* Decodes one vertex's residuals coded with table t in lane l into res; returns the next
 * vertex's table, or BAD / BAD_ESC. */
static inline __attribute__((always_inline)) uint32_t get_vertex(reader *r, uint32_t l, uint32_t t, int32_t *res)
{
    uint32_t s = get_sym(r, l, t);
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
            else if (!escape_residual(r, &res[a])) return BAD_ESC;
        }
    }
    return e >> 16 & 15u;
}

static inline bool in_range(int32_t q)
{
    return (uint32_t)(q + (CODEC_MAX_QUANT - 1)) < (uint32_t)(2 * CODEC_MAX_QUANT - 1);
}

/* Rebuilds vertices 1..nv-1 of a strand from residuals R: P[i] = prediction + R[i], one flat
 * loop per mode (the predictions of proto/CODEC.md). Deltas: K is the strand's lane in the
 * group's reference X (codec_motion_group: X[v] - X[v-1] = S[v]), coordinate i at K[8 i].
 * Returns false on an out-of-range value. */
static bool reconstruct(bool key, uint32_t mode, int32_t *restrict P, const int32_t *restrict K,
                        const int32_t *restrict N, uint32_t nv, const int32_t *restrict R)
{
#define KS(i) K[(i) * CODEC_LANES]
    const size_t n = (size_t)nv * 3u;
    bool ok = true;
    for (uint32_t a = 0; a < 3; a++) { /* vertex 1: the same under every mode */
        int32_t pred = key ? (N ? P[a] + N[3 + a] - N[a] : P[a]) : P[a] + (KS(3 + a) - KS(a));
        P[3 + a] = pred + R[3 + a];
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
        REBUILD(P[i - 3] + (KS(i) - KS(i - 3)) + (P[i - 3] - P[i - 6]) - (KS(i - 3) - KS(i - 6)))
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
        REBUILD(P[i - 3] + (KS(i) - KS(i - 3)))
    }
#undef REBUILD
#undef KS
    return true;
}

void codec_decoder_init(codec_decoder *dec)
{
    if (dec) memset(dec, 0, sizeof *dec);
}

void codec_decoder_free(codec_decoder *dec)
{
    if (!dec) return;
    free(dec->key_g);
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
        int32_t *r = realloc(dec->res, (size_t)nverts * 3u * CODEC_LANES * sizeof *r);
        if (!r) return core_fail(err, CORE_ENOMEM, "codec: out of memory for residuals");
        dec->res = r;
        int32_t *m = realloc(dec->key_m, (size_t)nverts * CODEC_GSTRIDE * sizeof *m);
        if (!m) return core_fail(err, CORE_ENOMEM, "codec: out of memory for residuals");
        dec->key_m = m;
        dec->res_cap = nverts;
    }
    /* the held keyframe's references, group by group (grown only by keyframes, which replace it) */
    size_t ng = (nq / 3u / nverts + CODEC_LANES - 1u) / CODEC_LANES * CODEC_KREF_SIZE(nverts);
    if (dec->key_cap < ng) {
        int32_t *k = realloc(dec->key_g, ng * sizeof *k);
        if (!k) return core_fail(err, CORE_ENOMEM, "codec: out of memory for %zu coordinates", nq);
        dec->key_g = k;
        dec->key_cap = ng;
    }
    if (dec->cap >= nq) return CORE_OK;
    int32_t *c = realloc(dec->cur_q, nq * sizeof *c);
    if (!c) return core_fail(err, CORE_ENOMEM, "codec: out of memory for %zu coordinates", nq);
    dec->cur_q = c;
    dec->cap = nq;
    return CORE_OK;
}

/* Decodes every strand of the frame into dec->cur_q, group by group: the lanes' modes, then
 * their vertex symbols and raw bits vertex by vertex across the lanes into residuals, then the
 * strands' predictions in order. The reader works on a local copy, written back at the end. */
static core_status decode_strands(codec_decoder *dec, const codec_frame_info *h, const codec_motion *motion, reader *rd,
                                  core_err *err)
{
    int32_t kprev[3] = { 0, 0, 0 }; /* the previous strand's moved root (deltas) */
    reader rl = *rd, *r = &rl;
    const bool key = h->keyframe;
    const uint32_t nv = h->nverts, nmodes = key ? CODEC_KEY_MODES : CODEC_DELTA_MODES;
    const size_t per = (size_t)nv * 3u;
    int32_t *const R = dec->res, *const X = dec->key_m;
    for (uint32_t j0 = 0; j0 < h->nstrands_sent; j0 += CODEC_LANES) {
        const uint32_t n = h->nstrands_sent - j0 < CODEC_LANES ? h->nstrands_sent - j0 : CODEC_LANES;
        uint32_t mode[CODEC_LANES], table[CODEC_LANES];
        for (uint32_t l = 0; l < n; l++) {
            mode[l] = get_sym(r, l, CODEC_T_MODE);
            if (mode[l] == BAD || mode[l] >= nmodes) goto bad_stream;
            table[l] = CODEC_T_ROOT;
        }
        for (uint32_t v = 0; v < nv; v++) {
            for (uint32_t l = 0; l < n; l++) {
                uint32_t t = get_vertex(r, l, table[l], R + (size_t)l * per + 3u * v);
                if (t >= BAD_ESC) {
                    if (t == BAD_ESC) goto bad_escape;
                    goto bad_stream;
                }
                table[l] = v ? t : CODEC_T_FIRST;
            }
        }
        if (r->overrun) goto bad_stream;
        if (!key) /* the group's moved roots and (as differences) moved segments */
            codec_motion_group(motion, dec->key_g + (size_t)(j0 / CODEC_LANES) * CODEC_KREF_SIZE(nv), X, nv,
                               j0 + CODEC_LANES < h->nstrands_sent, false);
        for (uint32_t l = 0; l < n; l++) {
            const uint32_t j = j0 + l;
            int32_t *P = dec->cur_q + (size_t)j * per;
            const int32_t *Rl = R + (size_t)l * per;
            const int32_t *N = j ? P - per : NULL;
            const int32_t *K = key ? NULL : X + l;
            for (uint32_t a = 0; a < 3; a++) {
                P[a] = (key ? (N ? N[a] : 0) : K[a * CODEC_LANES] + (N ? N[a] - kprev[a] : 0)) + Rl[a];
                if (!in_range(P[a])) goto bad_value;
            }
            if (!reconstruct(key, mode[l], P, K, N, nv, Rl)) goto bad_value;
            if (!key)
                for (uint32_t a = 0; a < 3; a++) kprev[a] = K[a * CODEC_LANES];
        }
    }
    *rd = rl;
    return CORE_OK;
bad_stream:
    return core_fail(err, CORE_EFORMAT, "codec: corrupt entropy-coded data (invalid symbol or stream overrun)");
bad_escape:
    return core_fail(err, CORE_EFORMAT, "codec: corrupt raw bits (escape exponent above %u)", CODEC_ESC_MAX);
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
    codec_motion motion;
    codec_motion_identity(&motion);
    if (!h.keyframe) {
        if (h.payload_len < CODEC_MOTION_BYTES) return core_fail(err, CORE_EFORMAT, "codec: truncated payload (no motion)");
        if (!codec_motion_read(pl, &motion))
            return core_fail(err, CORE_EFORMAT, "codec: invalid rigid motion (entry out of range or nonzero padding)");
        pos = CODEC_MOTION_BYTES;
    }
    st = codec_rans_read_tables(pl, h.payload_len, &pos, &tabs, dec->slots, err);
    if (st) return st;
    if (h.payload_len - pos < 4) return core_fail(err, CORE_EFORMAT, "codec: truncated payload (no stream length)");
    uint32_t rans_len = codec_get_u32(pl + pos);
    pos += 4;
    if (rans_len < CODEC_RANS_HEAD || rans_len % 2u || rans_len > h.payload_len - pos)
        return core_fail(err, CORE_EFORMAT, "codec: entropy stream length %u invalid for %zu payload bytes left",
                         rans_len, h.payload_len - pos);
    reader r = { .tabs = &tabs, .slots = dec->slots, .data = pl, .pos = pos + CODEC_RANS_HEAD, .end = pos + rans_len,
                 .bdata = pl, .bpos = pos + rans_len, .bend = h.payload_len };
    for (uint32_t l = 0; l < CODEC_LANES; l++) {
        r.x[l] = codec_get_u32(pl + pos + 4u * l);
        if (r.x[l] < CODEC_RANS_L) return core_fail(err, CORE_EFORMAT, "codec: invalid entropy coder state");
    }
    st = decode_strands(dec, &h, &motion, &r, err);
    if (st) return st;
    bool ends = r.pos == r.end;
    for (uint32_t l = 0; l < CODEC_LANES; l++) ends &= r.x[l] == CODEC_RANS_L;
    if (!ends) return core_fail(err, CORE_EFORMAT, "codec: entropy stream does not end where the frame says");
    size_t bits_avail = (r.bend - (pos + rans_len)) * 8u, bits_used = (r.bpos - (pos + rans_len)) * 8u - r.nacc;
    if (bits_used > bits_avail || bits_avail - bits_used >= 8u)
        return core_fail(err, CORE_EFORMAT, "codec: raw bit stream is %zu bits, frame used %zu", bits_avail,
                         bits_used);

    for (size_t i = 0; i < nq; i++) xyz_out[i] = (float)((double)dec->cur_q[i] * h.step);
    if (h.keyframe) { /* held as references of groups of 8, unused lanes repeating the last strand */
        const size_t per = (size_t)h.nverts * 3u;
        int32_t *const G = dec->key_m; /* one group's lattice coordinates, [vertex][axis][lane] */
        for (uint32_t j0 = 0; j0 < h.nstrands_sent; j0 += CODEC_LANES) {
            for (uint32_t l = 0; l < CODEC_LANES; l++) {
                const uint32_t j = j0 + l < h.nstrands_sent ? j0 + l : h.nstrands_sent - 1u;
                const int32_t *P = dec->cur_q + (size_t)j * per;
                for (size_t i = 0; i < per; i++) G[i * CODEC_LANES + l] = P[i];
            }
            codec_kref_group(G, h.nverts, dec->key_g + (size_t)(j0 / CODEC_LANES) * CODEC_KREF_SIZE(h.nverts), false);
        }
        dec->key = h;
        dec->key_valid = true;
    }
    if (info) *info = h;
    return CORE_OK;
}
