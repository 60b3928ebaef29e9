/* codec: the encoder (quantise, predict per strand, tokenise, rANS-code, frame). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "codec_enc.h"

_Static_assert(CODEC_NTABLES * CODEC_NSYM <= 65536, "symbols are packed as table * 343 + symbol in 16 bits");
_Static_assert(CODEC_GROUP == CODEC_LANES, "a group's strands are the rANS lanes");

/* Per-group scratch, in int32 units: P of this and the previous group, the reference X (moved
 * keyframe or previous strands), the candidates, then the tokens. */
static size_t group_size(uint32_t nverts)
{
    return (size_t)nverts * CODEC_GSTRIDE;
}

static size_t work_size(uint32_t nverts)
{
    return 3u * group_size(nverts) + (size_t)nverts * CODEC_CSTRIDE + (size_t)nverts * CODEC_GROUP * 2u +
           (size_t)nverts + (size_t)nverts * CODEC_XSTRIDE;
}

void codec_encoder_free(codec_encoder *enc)
{
    if (!enc) return;
    free(enc->key_q);
    free(enc->cur_q);
    free(enc->key_roots);
    free(enc->cur_roots);
    free(enc->syms);
    free(enc->counts);
    free(enc->bits);
    free(enc->rans);
    free(enc->rsyms);
    free(enc->rvsyms);
    free(enc->work);
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
    if (d.codec_id == 0) d.codec_id = CODEC_ID_STRAND;
    if (d.codec_id != CODEC_ID_STRAND && d.codec_id != CODEC_ID_HAIRMESH)
        return core_fail(err, CORE_EINVAL, "codec: unknown codec id %u", d.codec_id);
    if (d.codec_id == CODEC_ID_HAIRMESH && d.stride != 1)
        return core_fail(err, CORE_EINVAL, "codec: a hair mesh is sent whole (stride 1, not %u)", d.stride);
    if (!(d.max_error_m >= CODEC_MIN_ERROR && d.max_error_m <= CODEC_MAX_ERROR))
        return core_fail(err, CORE_EINVAL, "codec: max_error_m %g outside [%g, %g] m", (double)d.max_error_m,
                         (double)CODEC_MIN_ERROR, (double)CODEC_MAX_ERROR);
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
    enc->ngroups = (sent + CODEC_GROUP - 1u) / CODEC_GROUP;
    enc->step = codec_step_for_bound(d.max_error_m);
    enc->inv_step = 1.0 / enc->step;
    size_t nq = (size_t)enc->ngroups * CODEC_KREF_SIZE(nverts);
    enc->nsyms_max = (size_t)sent * (1u + (size_t)nverts);
    enc->bits_cap = (size_t)sent * nverts * 14u + 16u;
    enc->rans_cap = enc->nsyms_max * 2u + 64u;
    enc->key_q = calloc(nq, sizeof *enc->key_q);
    enc->cur_q = calloc(nq, sizeof *enc->cur_q);
    enc->key_roots = calloc((size_t)sent * 3u, sizeof *enc->key_roots);
    enc->cur_roots = calloc((size_t)sent * 3u, sizeof *enc->cur_roots);
    enc->syms = malloc(enc->nsyms_max * sizeof *enc->syms);
    enc->counts = malloc((size_t)CODEC_HIST_COPIES * CODEC_HIST_SIZE * sizeof *enc->counts);
    enc->bits = malloc(enc->bits_cap);
    enc->rans = malloc(enc->rans_cap);
    enc->rsyms = malloc((size_t)CODEC_HIST_SIZE * sizeof *enc->rsyms);
    enc->rvsyms = malloc((size_t)CODEC_HIST_SIZE * sizeof *enc->rvsyms);
    enc->work = calloc(work_size(nverts), sizeof *enc->work);
    if (!enc->key_q || !enc->cur_q || !enc->key_roots || !enc->cur_roots || !enc->syms || !enc->counts ||
        !enc->bits || !enc->rans || !enc->rsyms || !enc->rvsyms || !enc->work) {
        codec_encoder_free(enc);
        return core_fail(err, CORE_ENOMEM, "codec: out of memory for %u x %u vertices", sent, nverts);
    }
    return CORE_OK;
}

/* Quantises sent strand j alone into lane 0 of the group P (the fast path, else the careful
 * one). */
static core_status quantize_strand(const codec_encoder *enc, const codec_quant *qz, const float *xyz, uint32_t j,
                                   int32_t *P, core_err *err)
{
    const float *src = xyz + (size_t)j * enc->desc.stride * enc->nverts * 3u;
    const float *const srcs[CODEC_GROUP] = { src, src, src, src, src, src, src, src };
    if (!(codec_quant_group(qz, srcs, enc->nverts, P, NULL, enc->portable) & 1u)) return CORE_OK;
    return codec_quant_careful(qz, src, enc->nverts, P, 0, j * enc->desc.stride, err);
}

/* How many strands ahead quantize_roots prefetches a root. */
#define ROOT_AHEAD 16u

/* The motion is estimated from at most about this many roots (every k-th strand). */
#define ROOT_SAMPLES 1024u

static uint32_t root_step(const codec_encoder *enc)
{
    return enc->nstrands_sent >= 2u * ROOT_SAMPLES ? enc->nstrands_sent / ROOT_SAMPLES : 1u;
}

/* The roots of every step-th strand of this frame into enc->cur_roots (for the motion
 * estimate), as the group pass will quantise them; on a bad coordinate in one of them, the first
 * one in strand order fails. */
static core_status quantize_roots(codec_encoder *enc, const codec_quant *qz, const float *xyz, uint32_t step,
                                  core_err *err)
{
    int32_t *P = enc->work;
    const size_t per = (size_t)enc->desc.stride * enc->nverts * 3u;
    for (uint32_t j = 0; j < enc->nstrands_sent; j += step) {
        int32_t *q = enc->cur_roots + 3u * j;
        if (j + ROOT_AHEAD * step < enc->nstrands_sent) __builtin_prefetch(xyz + (j + ROOT_AHEAD * step) * per);
        if (codec_quant_root(qz, xyz + j * per, q)) continue;
        if (quantize_strand(enc, qz, xyz, j, P, err)) {
            for (uint32_t i = 0; i <= j; i++)
                if (quantize_strand(enc, qz, xyz, i, P, err)) return CORE_EINVAL;
        }
        for (uint32_t a = 0; a < 3; a++) q[a] = P[CODEC_GAT(0, a, 0)];
    }
    return CORE_OK;
}

/* Quantises group g (lanes past the last strand repeat it) into P; the careful path for the
 * lanes the fast one refuses. */
static core_status quantize_group(codec_encoder *enc, const codec_quant *qz, const float *xyz, uint32_t g,
                                  uint32_t nreal, int32_t *P, core_err *err)
{
    const uint32_t nv = enc->nverts;
    const size_t per = (size_t)enc->desc.stride * nv * 3u;
    const float *src[CODEC_GROUP];
    for (uint32_t l = 0; l < CODEC_GROUP; l++) src[l] = xyz + ((size_t)g * CODEC_GROUP + (l < nreal ? l : nreal - 1u)) * per;
    const float *next[CODEC_GROUP]; /* the next group's strands, prefetched meanwhile */
    const uint32_t ahead = g + 1u, left = ahead < enc->ngroups ? enc->nstrands_sent - ahead * CODEC_GROUP : 0;
    for (uint32_t l = 0; l < CODEC_GROUP && left; l++)
        next[l] = xyz + ((size_t)ahead * CODEC_GROUP + (l < left ? l : left - 1u)) * per;
    uint32_t bad = codec_quant_group(qz, src, nv, P, left ? next : NULL, enc->portable);
    for (uint32_t l = 0; l < nreal; l++) {
        if (!(bad >> l & 1u)) continue;
        enc->careful++;
        core_status st = codec_quant_careful(qz, src[l], nv, P, l, (g * CODEC_GROUP + l) * enc->desc.stride, err);
        if (st) return st;
    }
    for (uint32_t l = nreal; l < CODEC_GROUP; l++)
        for (uint32_t v = 0; v < nv; v++)
            for (uint32_t a = 0; a < 3; a++) P[CODEC_GAT(v, a, l)] = P[CODEC_GAT(v, a, nreal - 1u)];
    return CORE_OK;
}

/* Pass 1, group by group: quantise, build the reference, choose each strand's cheapest mode,
 * tokenise, emit the strands' symbols and raw bits in order. */
static core_status tokenize(codec_encoder *enc, const codec_quant *qz, const float *xyz, bool key,
                            const codec_motion *motion, codec_emitter *e, core_err *err)
{
    const uint32_t nv = enc->nverts;
    const bool portable = enc->portable;
    const size_t gs = group_size(nv);
    int32_t *const Pg[2] = { enc->work, enc->work + gs }, *const X = enc->work + 2u * gs;
    int32_t *const cand = enc->work + 3u * gs;
    uint32_t *const tw = (uint32_t *)(void *)(cand + (size_t)nv * CODEC_CSTRIDE);
    const size_t nvl = (size_t)nv * CODEC_GROUP;
    uint16_t *const symtmp = (uint16_t *)(void *)(tw + nvl); /* a partial group's symbols */
    codec_tokens tok = { .cand = cand, .pbits = (uint64_t *)(void *)tw, .esc = (uint8_t *)(void *)(tw + nvl + nvl / 2u),
                         .xbits = tw + nvl + nvl / 2u + nv };
    int32_t kprev[3] = { 0, 0, 0 }; /* root of the previous strand in the moved keyframe */
    for (uint32_t g = 0; g < enc->ngroups; g++) {
        const uint32_t j0 = g * CODEC_GROUP, nreal = enc->nstrands_sent - j0 < CODEC_GROUP ? enc->nstrands_sent - j0 : CODEC_GROUP;
        int32_t *const P = Pg[g & 1u];
        const int32_t *const Pprev = Pg[(g + 1u) & 1u];
        core_status st = quantize_group(enc, qz, xyz, g, nreal, P, err);
        if (st) return st;
        if (key) {
            codec_kref_group(P, nv, enc->cur_q + (size_t)g * CODEC_KREF_SIZE(nv), portable);
            for (uint32_t l = 0; l < nreal; l++)
                for (uint32_t a = 0; a < 3; a++) enc->cur_roots[3u * (j0 + l) + a] = P[CODEC_GAT(0, a, l)];
            for (uint32_t v = 0; v < nv; v++) /* X = the previous strand, zeros before the first */
                for (uint32_t a = 0; a < 3; a++) {
                    X[CODEC_GAT(v, a, 0)] = g ? Pprev[CODEC_GAT(v, a, CODEC_GROUP - 1u)] : 0;
                    memcpy(X + CODEC_GAT(v, a, 1), P + CODEC_GAT(v, a, 0), (CODEC_GROUP - 1u) * sizeof *X);
                }
        } else {
            codec_motion_group(motion, enc->key_q + (size_t)g * CODEC_KREF_SIZE(nv), X, nv, g + 1u < enc->ngroups,
                               portable);
        }
        uint32_t cost[CODEC_CANDS * CODEC_GROUP], mode[CODEC_GROUP];
        int32_t root[3 * CODEC_GROUP];
        codec_costs_group(P, X, nv, key, cost, cand, portable);
        for (uint32_t l = 0; l < CODEC_GROUP; l++) {
            const uint32_t j = j0 + l;
            uint32_t m = 0;
            for (uint32_t k = 1; k < CODEC_CANDS; k++) {
                if (key && k == 1u && j == 0) continue; /* no neighbour: the same as mode 0 */
                if (cost[k * CODEC_GROUP + l] < cost[m * CODEC_GROUP + l]) m = k;
            }
            mode[l] = m;
            for (uint32_t a = 0; a < 3; a++) {
                int32_t p0 = P[CODEC_GAT(0, a, l)], x0 = X[CODEC_GAT(0, a, l)], pred = x0;
                if (!key && j > 0) {
                    int32_t n0 = l ? P[CODEC_GAT(0, a, l - 1u)] : Pprev[CODEC_GAT(0, a, CODEC_GROUP - 1u)];
                    int32_t kn0 = l ? X[CODEC_GAT(0, a, l - 1u)] : kprev[a];
                    pred = x0 + (n0 - kn0);
                }
                root[a * CODEC_GROUP + l] = p0 - pred;
            }
        }
        for (uint32_t a = 0; a < 3; a++) kprev[a] = X[CODEC_GAT(0, a, CODEC_GROUP - 1u)];
        tok.mode = mode;
        tok.root = root;
        /* a full group's symbols go straight to their place in the frame, after its modes */
        tok.sym = nreal == CODEC_GROUP ? e->syms + e->nsyms + CODEC_GROUP : symtmp;
        uint32_t esc = codec_tokens_group(&tok, nv, nreal < CODEC_GROUP, portable);
        codec_emit_group(e, &tok, mode, nreal, nv, esc);
    }
    return CORE_OK;
}

/* The checks the decoder makes of the header's simulation snapshot (codec_core_header). */
static core_status check_sim(const codec_sim_info *sim, core_err *err)
{
    if (!isfinite(sim->sim_time)) return core_fail(err, CORE_EINVAL, "codec: sim time is not finite");
    double norm2 = 0.0;
    for (int i = 0; i < 3; i++)
        if (!isfinite(sim->head_pos[i])) return core_fail(err, CORE_EINVAL, "codec: head position is not finite");
    for (int i = 0; i < 4; i++) {
        if (!isfinite(sim->head_rot[i])) return core_fail(err, CORE_EINVAL, "codec: head rotation is not finite");
        norm2 += (double)sim->head_rot[i] * (double)sim->head_rot[i];
    }
    if (!(norm2 >= 1.0 - CODEC_HEAD_NORM_TOL && norm2 <= 1.0 + CODEC_HEAD_NORM_TOL)) /* as the decoder checks it */
        return core_fail(err, CORE_EINVAL, "codec: head rotation is not a unit quaternion (squared norm %.9g)", norm2);
    return CORE_OK;
}

core_status codec_encode(codec_encoder *enc, const float *xyz, uint64_t seq, const codec_sim_info *sim,
                         bool force_key, codec_buf *out, core_err *err)
{
    if (!enc || !enc->cur_q || !xyz || !sim || !out)
        return core_fail(err, CORE_EINVAL, "codec: NULL or uninitialised encoder/positions/snapshot/buffer");
    core_status st = check_sim(sim, err);
    if (st) return st;
    if (enc->key_valid && seq <= enc->last_seq)
        return core_fail(err, CORE_EINVAL, "codec: sequence %llu does not follow %llu", (unsigned long long)seq,
                         (unsigned long long)enc->last_seq);
    bool key = force_key || !enc->key_valid || enc->since_key + 1u >= enc->desc.key_interval;
    codec_quant qz;
    codec_quant_setup(&qz, enc->desc.max_error_m);
    enc->careful = 0;

    codec_motion motion;
    codec_motion_identity(&motion);
    if (!key) {
        const uint32_t step = root_step(enc);
        st = quantize_roots(enc, &qz, xyz, step, err);
        if (st) return st;
        codec_motion_estimate(enc->key_roots, enc->cur_roots, enc->nstrands_sent, step, &motion);
    }

    memset(enc->counts, 0, (size_t)CODEC_HIST_COPIES * CODEC_HIST_SIZE * sizeof *enc->counts);
    codec_emitter e = { .syms = enc->syms, .nsyms = 0, .counts = enc->counts, .bits = enc->bits, .acc = 0, .n = 0 };
    st = tokenize(enc, &qz, xyz, key, &motion, &e, err);
    if (st) return st;
    size_t nbits_bytes = (size_t)(codec_emit_finish(&e) - enc->bits);

    uint32_t *counts = enc->counts;
    for (uint32_t c = 1; c < CODEC_HIST_COPIES; c++)
        for (size_t i = 0; i < CODEC_HIST_SIZE; i++) counts[i] += counts[(size_t)c * CODEC_HIST_SIZE + i];
    uint16_t freq[CODEC_NTABLES][CODEC_NSYM];
    uint32_t nsym[CODEC_NTABLES];
    codec_rans_sym *rs = enc->rsyms;
    for (uint32_t t = 0; t < CODEC_NTABLES; t++) {
        nsym[t] = codec_rans_normalize(counts + t * CODEC_NSYM, CODEC_NSYM, freq[t]);
        uint32_t start = 0;
        for (uint32_t s = 0; s < nsym[t]; s++) {
            if (freq[t][s]) codec_rans_sym_init(&rs[t * CODEC_NSYM + s], &enc->rvsyms[t * CODEC_NSYM + s], start, freq[t][s]);
            start += freq[t][s];
        }
    }

    /* rANS, last symbol first; the symbols of lane l of a group use state l. */
    uint8_t *end = enc->rans + enc->rans_cap;
    uint32_t x[CODEC_LANES];
    const uint32_t tail_lanes = enc->nstrands_sent % CODEC_GROUP;
    const size_t ntail = (size_t)tail_lanes * (1u + enc->nverts);
    uint8_t *p = codec_rans_encode(e.syms, e.nsyms - ntail, ntail, tail_lanes, rs, enc->rvsyms, end, x,
                                   enc->portable);
    for (int k = CODEC_LANES - 1; k >= 0; k--) {
        p -= 4;
        codec_put_u32(p, x[k]);
    }
    size_t rans_len = (size_t)(end - p);

    size_t max_len = CODEC_HEADER_SIZE + CODEC_MOTION_BYTES + (size_t)CODEC_NTABLES * 5u * (CODEC_NSYM + 1u) + 4u + rans_len + nbits_bytes;
    st = codec_buf_reserve(out, max_len, err);
    if (st) return st;
    uint8_t *w = out->data + CODEC_HEADER_SIZE;
    if (!key) {
        codec_motion_write(w, &motion);
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
        .seq = seq, .ref_seq = key ? seq : enc->key_seq, .sim = *sim, .step = enc->step,
        .max_error_m = enc->desc.max_error_m, .keyframe = key, .codec_id = enc->desc.codec_id, .nstrands_total = enc->nstrands_total,
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
        t = enc->key_roots;
        enc->key_roots = enc->cur_roots;
        enc->cur_roots = t;
        enc->key_seq = seq;
        enc->key_valid = true;
        enc->since_key = 0;
    } else {
        enc->since_key++;
    }
    return CORE_OK;
}
