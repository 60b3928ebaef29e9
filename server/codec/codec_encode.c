/* codec: the encoder (quantise, predict per strand, tokenise, rANS-code, frame). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "codec_rans.h"

_Static_assert(CODEC_NTABLES <= 16 && CODEC_NSYM <= 512, "symbols are packed as table << 9 | sym");

/* Bit writer for the raw bits that follow escape tokens (LSB first). */
typedef struct bitw {
    uint8_t *p;
    uint64_t acc;
    uint32_t n;
} bitw;

static inline void bitw_put(bitw *w, uint32_t v, uint32_t nb)
{
    w->acc |= (uint64_t)v << w->n;
    w->n += nb;
    while (w->n >= 8) {
        *w->p++ = (uint8_t)w->acc;
        w->acc >>= 8;
        w->n -= 8;
    }
}

/* Pass-1 state: symbols, their histogram, raw bits. */
typedef struct emitter {
    uint16_t *syms;
    size_t nsyms;
    uint32_t (*counts)[CODEC_NSYM];
    bitw bits;
} emitter;

static inline void emit_symbol(emitter *e, uint32_t table, uint32_t sym)
{
    e->syms[e->nsyms++] = (uint16_t)(table << 9 | sym);
    e->counts[table][sym]++;
}

static inline uint32_t mag(int32_t r)
{
    return r < 0 ? (uint32_t)-r : (uint32_t)r;
}

/* Emits one vertex's residuals (classes in one symbol, then raw bits per axis); returns the
 * table for the next vertex. */
static inline uint32_t emit_vertex(emitter *e, uint32_t table, const int32_t *r)
{
    uint32_t m0 = mag(r[0]), m1 = mag(r[1]), m2 = mag(r[2]), c[3];
    if ((m0 | m1 | m2) < 32u) {
        /* class = floor(log2(2m + 1)); field = sign | bits below the leading one, c bits */
        uint32_t c0 = 31u - (uint32_t)__builtin_clz(2u * m0 + 1u), c1 = 31u - (uint32_t)__builtin_clz(2u * m1 + 1u),
                 c2 = 31u - (uint32_t)__builtin_clz(2u * m2 + 1u);
        uint32_t f0 = ((m0 << 1) | ((uint32_t)r[0] >> 31)) & ((1u << c0) - 1u);
        uint32_t f1 = ((m1 << 1) | ((uint32_t)r[1] >> 31)) & ((1u << c1) - 1u);
        uint32_t f2 = ((m2 << 1) | ((uint32_t)r[2] >> 31)) & ((1u << c2) - 1u);
        bitw_put(&e->bits, f0 | f1 << c0 | f2 << (c0 + c1), c0 + c1 + c2);
        emit_symbol(e, table, c0 + CODEC_NCLASS * c1 + CODEC_NCLASS * CODEC_NCLASS * c2);
        return codec_body_table(c0, c1, c2);
    }
    uint32_t esc[3], nesc = 0;
    for (uint32_t a = 0; a < 3; a++) {
        uint32_t m = mag(r[a]), sign = (uint32_t)r[a] >> 31;
        c[a] = codec_class(m);
        if (c[a] == 0) continue;
        if (c[a] < CODEC_ESCAPE) {
            bitw_put(&e->bits, ((m << 1) | sign) & ((1u << c[a]) - 1u), c[a]);
        } else {
            uint32_t ex = 31u - (uint32_t)__builtin_clz(m);
            esc[nesc++] = ex - 5u;
            bitw_put(&e->bits, sign, 1);
            bitw_put(&e->bits, m - (1u << ex), ex);
        }
    }
    emit_symbol(e, table, c[0] + CODEC_NCLASS * c[1] + CODEC_NCLASS * CODEC_NCLASS * c[2]);
    for (uint32_t k = 0; k < nesc; k++) emit_symbol(e, CODEC_T_ESC, esc[k]);
    return codec_body_table(c[0], c[1], c[2]);
}

/* Summed magnitude classes of r[0..n) (a bit-cost estimate), via the float exponent of 2|r|+1
 * so that the loop vectorises. */
static uint32_t est_cost(const int32_t *r, size_t n)
{
    uint32_t cost = 0;
    for (size_t i = 0; i < n; i++) {
        union { float f; uint32_t u; } v = { .f = (float)(2u * mag(r[i]) + 1u) };
        cost += (v.u >> 23) - 127u;
    }
    return cost;
}

/* Residuals of vertices 1..nverts-1 of one strand under one prediction mode, into r[3..);
 * returns their estimated cost. Same predictions as codec_predict, written as flat loops. */
static uint32_t residuals(bool key, uint32_t mode, const int32_t *restrict P, const int32_t *restrict K,
                          const int32_t *restrict N, uint32_t nverts, int32_t *restrict r)
{
    const size_t n = (size_t)nverts * 3u;
    for (uint32_t a = 0; a < 3; a++) r[3 + a] = P[3 + a] - codec_predict(key, mode, P, K, N, 1, a);
    size_t i = 6;
    if (key) {
        if (mode == 1u && N) {
            for (; i < n; i++) r[i] = P[i] - (P[i - 3] + N[i] - N[i - 3]);
        } else {
            if (mode == 2u)
                for (; i < n && i < 9; i++) r[i] = P[i] - (2 * P[i - 3] - P[i - 6]);
            if (mode == 2u)
                for (; i < n; i++) r[i] = P[i] - codec_smooth(P, (uint32_t)i);
            else
                for (; i < n; i++) r[i] = P[i] - (2 * P[i - 3] - P[i - 6]);
        }
    } else if (mode == 1u) {
        for (; i < n; i++) r[i] = P[i] - (2 * P[i - 3] + K[i] - 2 * K[i - 3] - P[i - 6] + K[i - 6]);
    } else if (mode == 2u) {
        for (; i < n; i++) r[i] = P[i] - (2 * P[i - 3] - P[i - 6]);
    } else if (mode == 3u) {
        for (; i < n && i < 9; i++) r[i] = P[i] - (2 * P[i - 3] - P[i - 6]);
        for (; i < n; i++) r[i] = P[i] - codec_smooth(P, (uint32_t)i);
    } else {
        for (; i < n; i++) r[i] = P[i] - (P[i - 3] + K[i] - K[i - 3]);
    }
    return est_cost(r + 3, n - 3);
}

void codec_encoder_free(codec_encoder *enc)
{
    if (!enc) return;
    free(enc->key_q);
    free(enc->cur_q);
    free(enc->key_m);
    free(enc->syms);
    free(enc->bits);
    free(enc->rans);
    free(enc->res);
    free(enc->rsyms);
    memset(enc, 0, sizeof *enc);
}

core_status codec_encoder_init(codec_encoder *enc, const codec_desc *desc, uint32_t nstrands,
                               uint32_t nverts, core_err *err)
{
    if (!enc) return core_fail(err, CORE_EINVAL, "codec: NULL encoder");
    memset(enc, 0, sizeof *enc);
    codec_desc d = { 0 };
    if (desc) d = *desc;
    if (d.max_error_m == 0.0f) d.max_error_m = CODEC_DEFAULT_MAX_ERROR;
    if (d.key_interval == 0) d.key_interval = CODEC_DEFAULT_KEY_INTERVAL;
    if (d.stride == 0) d.stride = 1;
    if (!(d.max_error_m >= 1e-5f && d.max_error_m <= 0.1f))
        return core_fail(err, CORE_EINVAL, "codec: max_error_m %g outside [1e-5, 0.1] m", (double)d.max_error_m);
    if (nstrands < 1) return core_fail(err, CORE_EINVAL, "codec: no strands");
    if (nverts < 2 || nverts > CODEC_MAX_NVERTS)
        return core_fail(err, CORE_EINVAL, "codec: %u vertices per strand outside [2, %u]", nverts,
                         CODEC_MAX_NVERTS);
    uint32_t sent = (uint32_t)(((uint64_t)nstrands + d.stride - 1u) / d.stride);
    if ((uint64_t)sent * nverts > CODEC_MAX_VERTICES)
        return core_fail(err, CORE_EINVAL, "codec: %u x %u vertices exceed the limit %u", sent, nverts,
                         CODEC_MAX_VERTICES);
    enc->desc = d;
    enc->nstrands_total = nstrands;
    enc->nstrands_sent = sent;
    enc->nverts = nverts;
    enc->step = codec_step_for_bound(d.max_error_m);
    enc->inv_step = 1.0 / enc->step;
    size_t nq = (size_t)sent * nverts * 3u;
    enc->nsyms_max = (size_t)sent * (1u + 4u * (size_t)nverts);
    enc->bits_cap = (size_t)sent * nverts * 12u + 16u;
    enc->rans_cap = enc->nsyms_max * 2u + 16u;
    enc->key_q = malloc(nq * sizeof *enc->key_q);
    enc->cur_q = malloc(nq * sizeof *enc->cur_q);
    enc->key_m = malloc(nq * sizeof *enc->key_m);
    enc->syms = malloc(enc->nsyms_max * sizeof *enc->syms);
    enc->bits = malloc(enc->bits_cap);
    enc->rans = malloc(enc->rans_cap);
    enc->res = malloc(2u * (size_t)nverts * 3u * sizeof *enc->res);
    enc->rsyms = malloc((size_t)CODEC_NTABLES * CODEC_NSYM * sizeof *enc->rsyms);
    if (!enc->key_q || !enc->cur_q || !enc->key_m || !enc->syms || !enc->bits || !enc->rans || !enc->res || !enc->rsyms) {
        codec_encoder_free(enc);
        return core_fail(err, CORE_ENOMEM, "codec: out of memory for %u x %u vertices", sent, nverts);
    }
    return CORE_OK;
}

/* Quantises one coordinate carefully: the nearest lattice point whose float32 reconstruction
 * is within the bound (the nearest one or a neighbour). */
static core_status quantize_one(const codec_encoder *enc, float x, uint32_t strand, size_t vert, int32_t *out,
                                core_err *err)
{
    const double step = enc->step, t = (double)x * enc->inv_step;
    const float bound = enc->desc.max_error_m;
    if (!(fabs(t) < (double)(CODEC_MAX_QUANT - 2)))
        return core_fail(err, CORE_EINVAL, "codec: strand %u vertex %zu coordinate %g is %s", strand, vert, (double)x,
                         isfinite(x) ? "out of range for this error bound" : "not finite");
    int32_t v = (int32_t)lrint(t);
    if (!(fabsf((float)((double)v * step) - x) <= bound)) {
        int32_t alt = (float)((double)v * step) < x ? v + 1 : v - 1;
        if (!(fabsf((float)((double)alt * step) - x) <= bound))
            return core_fail(err, CORE_EINVAL, "codec: coordinate %g cannot be held within %g m in float32", (double)x,
                             (double)bound);
        v = alt;
    }
    *out = v;
    return CORE_OK;
}

/* Quantises the sent strands into enc->cur_q. Vectorisable passes check the range (and NaN),
 * round (truncation of a shifted positive value, i.e. floor(t + 0.5)) and check each float32
 * reconstruction against the bound; a strand with any flag is redone one coordinate at a time. */
static core_status quantize(codec_encoder *enc, const float *xyz, core_err *err)
{
    const double step = enc->step, inv = enc->inv_step, shift = (double)(2 * CODEC_MAX_QUANT);
    const float bound = enc->desc.max_error_m, xlim = (float)((double)(CODEC_MAX_QUANT - 4) * step);
    const size_t per = (size_t)enc->nverts * 3u;
    for (uint32_t j = 0; j < enc->nstrands_sent; j++) {
        const float *restrict src = xyz + (size_t)j * enc->desc.stride * per;
        int32_t *restrict q = enc->cur_q + (size_t)j * per;
        int bad = 0;
        for (size_t i = 0; i < per; i++) bad |= !(fabsf(src[i]) <= xlim);
        if (!bad) {
            for (size_t i = 0; i < per; i++)
                q[i] = (int32_t)((double)src[i] * inv + (shift + 0.5)) - 2 * CODEC_MAX_QUANT;
            for (size_t i = 0; i < per; i++) bad |= fabsf((float)((double)q[i] * step) - src[i]) > bound;
            if (!bad) continue;
        }
        for (size_t i = 0; i < per; i++) {
            core_status st = quantize_one(enc, src[i], j * enc->desc.stride, i / 3u, &q[i], err);
            if (st) return st;
        }
    }
    return CORE_OK;
}

/* Pass 1: per strand the cheapest mode, then its residuals into symbols and raw bits. */
static void tokenize(codec_encoder *enc, bool key, emitter *e)
{
    const uint32_t nv = enc->nverts, nmodes = key ? CODEC_KEY_MODES : CODEC_DELTA_MODES;
    const size_t per = (size_t)nv * 3u;
    int32_t *best = enc->res, *trial = enc->res + per;
    for (uint32_t j = 0; j < enc->nstrands_sent; j++) {
        const int32_t *P = enc->cur_q + (size_t)j * per;
        const int32_t *K = key ? NULL : enc->key_m + (size_t)j * per;
        const int32_t *N = j ? P - per : NULL;
        const int32_t *KN = (j && !key) ? K - per : NULL;
        uint32_t mode = 0, best_cost = residuals(key, 0, P, K, N, nv, best);
        for (uint32_t m = 1; m < nmodes; m++) {
            if (!N && key && m == 1u) continue; /* same as mode 0 */
            uint32_t c = residuals(key, m, P, K, N, nv, trial);
            if (c < best_cost) {
                int32_t *t = best;
                best = trial;
                trial = t;
                best_cost = c;
                mode = m;
            }
        }
        emit_symbol(e, CODEC_T_MODE, mode);
        for (uint32_t a = 0; a < 3; a++) best[a] = P[a] - codec_predict_root(key, K, N, KN, a);
        emit_vertex(e, CODEC_T_ROOT, best);
        uint32_t table = CODEC_T_FIRST;
        for (uint32_t v = 1; v < nv; v++) table = emit_vertex(e, table, best + 3u * v);
    }
}

core_status codec_encode(codec_encoder *enc, const float *xyz, uint64_t seq, double sim_time,
                         bool force_key, codec_buf *out, core_err *err)
{
    if (!enc || !enc->cur_q || !xyz || !out)
        return core_fail(err, CORE_EINVAL, "codec: NULL or uninitialised encoder/positions/buffer");
    if (!isfinite(sim_time)) return core_fail(err, CORE_EINVAL, "codec: sim time is not finite");
    if (enc->key_valid && seq <= enc->last_seq)
        return core_fail(err, CORE_EINVAL, "codec: sequence %llu does not follow %llu", (unsigned long long)seq,
                         (unsigned long long)enc->last_seq);
    bool key = force_key || !enc->key_valid || enc->since_key + 1u >= enc->desc.key_interval;
    core_status st = quantize(enc, xyz, err);
    if (st) return st;

    float motion[12];
    if (!key) {
        const size_t per = (size_t)enc->nverts * 3u;
        codec_motion_estimate(enc->key_q, enc->cur_q, enc->nstrands_sent, per, motion);
        codec_motion_apply(motion, enc->key_q, enc->key_m, (size_t)enc->nstrands_sent * enc->nverts);
    }

    static const uint32_t zero_counts[CODEC_NTABLES][CODEC_NSYM];
    uint32_t counts[CODEC_NTABLES][CODEC_NSYM];
    memcpy(counts, zero_counts, sizeof counts);
    emitter e = { .syms = enc->syms, .nsyms = 0, .counts = counts, .bits = { .p = enc->bits, .acc = 0, .n = 0 } };
    tokenize(enc, key, &e);
    if (e.bits.n) bitw_put(&e.bits, 0, 8u - e.bits.n);
    size_t nbits_bytes = (size_t)(e.bits.p - enc->bits);

    uint16_t freq[CODEC_NTABLES][CODEC_NSYM];
    uint32_t nsym[CODEC_NTABLES];
    codec_rans_sym *rs = enc->rsyms;
    for (uint32_t t = 0; t < CODEC_NTABLES; t++) {
        nsym[t] = codec_rans_normalize(counts[t], CODEC_NSYM, freq[t]);
        uint32_t start = 0;
        for (uint32_t s = 0; s < nsym[t]; s++) {
            if (freq[t][s]) codec_rans_sym_init(&rs[t * CODEC_NSYM + s], start, freq[t][s]);
            start += freq[t][s];
        }
    }

    /* rANS, last symbol first; symbol i uses state i & 1. */
    uint8_t *end = enc->rans + enc->rans_cap, *p = end;
    uint32_t x[2] = { CODEC_RANS_L, CODEC_RANS_L };
    for (size_t i = e.nsyms; i-- > 0;) {
        uint16_t s = e.syms[i];
        codec_rans_put(&x[i & 1u], &p, &rs[(s >> 9) * CODEC_NSYM + (s & 0x1ffu)]);
    }
    for (int k = 1; k >= 0; k--) {
        p -= 4;
        codec_put_u32(p, x[k]);
    }
    size_t rans_len = (size_t)(end - p);

    size_t max_len = CODEC_HEADER_SIZE + CODEC_MOTION_BYTES + (size_t)CODEC_NTABLES * 5u * (CODEC_NSYM + 1u) + 4u + rans_len + nbits_bytes;
    st = codec_buf_reserve(out, max_len, err);
    if (st) return st;
    uint8_t *w = out->data + CODEC_HEADER_SIZE;
    if (!key) {
        for (int k = 0; k < 12; k++) {
            uint32_t u;
            memcpy(&u, &motion[k], 4);
            codec_put_u32(w + 4 * k, u);
        }
        w += CODEC_MOTION_BYTES;
    }
    for (uint32_t t = 0; t < CODEC_NTABLES; t++) w = codec_rans_write_table(w, freq[t], nsym[t]);
    codec_put_u32(w, (uint32_t)rans_len);
    w += 4;
    memcpy(w, p, rans_len);
    w += rans_len;
    memcpy(w, enc->bits, nbits_bytes);
    w += nbits_bytes;
    size_t payload = (size_t)(w - out->data) - CODEC_HEADER_SIZE;
    if (payload > UINT32_MAX) return core_fail(err, CORE_EINVAL, "codec: frame payload over 4 GiB");

    codec_frame_info h = {
        .seq = seq, .ref_seq = key ? seq : enc->key_seq, .sim_time = sim_time, .step = enc->step,
        .max_error_m = enc->desc.max_error_m, .keyframe = key, .nstrands_total = enc->nstrands_total,
        .nstrands_sent = enc->nstrands_sent, .nverts = enc->nverts, .stride = enc->desc.stride,
        .payload_len = (uint32_t)payload,
    };
    codec_header_write(out->data, &h);
    codec_put_u32(out->data + CODEC_OFF_CRC, codec_frame_crc(out->data, payload));
    out->len = CODEC_HEADER_SIZE + payload;

    enc->last_seq = seq;
    if (key) {
        int32_t *t = enc->key_q;
        enc->key_q = enc->cur_q;
        enc->cur_q = t;
        enc->key_seq = seq;
        enc->key_valid = true;
        enc->since_key = 0;
    } else {
        enc->since_key++;
    }
    return CORE_OK;
}
