/* Tests for server/codec's decoder on frames of every prediction mode (keyframe modes 0-2, delta
 * modes 0-3), partial groups and escapes, built by a small reference encoder written here from
 * proto/CODEC.md: the encoder itself never writes delta mode 3, so these frames are what keeps
 * the decoder's side of it tested. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "codec/codec_enc.h"

/* A frame to build: lattice q of ns strands x nv vertices (strand-major xyz), one mode per strand,
 * and for deltas the held keyframe's lattice kq and the motion. */
typedef struct ref_frame {
    bool key;
    uint64_t seq, ref_seq;
    uint32_t ns, nv;
    double step;
    float bound;
    const int32_t *q, *kq;
    const uint32_t *modes;
    codec_motion motion;
} ref_frame;

/* Axis a of strand j's vertex v in lattice x (strand-major). */
static int32_t at(const ref_frame *f, const int32_t *x, uint32_t j, uint32_t v, uint32_t a)
{
    return x[((size_t)j * f->nv + v) * 3u + a];
}

/* S[v]_a of proto/CODEC.md, written out: the keyframe segment clamped to 15 bits and rotated. */
static int32_t moved_seg(const ref_frame *f, uint32_t j, uint32_t v, uint32_t a)
{
    int32_t d[3];
    for (uint32_t b = 0; b < 3; b++) {
        int32_t s = at(f, f->kq, j, v, b) - at(f, f->kq, j, v - 1u, b);
        d[b] = s < -32767 ? -32767 : s > 32767 ? 32767 : s;
    }
    const int32_t *r = f->motion.rho + 3u * a;
    return (r[0] * d[0] + r[1] * d[1] + r[2] * d[2] + 8192) >> 14;
}

/* K'[0]_a of strand j: the keyframe root rotated (exact, floor) and translated, clamped. */
static int32_t moved_root(const ref_frame *f, uint32_t j, uint32_t a)
{
    const int32_t *r = f->motion.rho + 3u * a;
    int64_t s = 0;
    for (uint32_t b = 0; b < 3; b++) s += (int64_t)r[b] * at(f, f->kq, j, 0, b);
    const int64_t u = s + 8192;
    const int64_t w = u / 16384 - (u % 16384 < 0) + f->motion.t[a]; /* floor division */
    const int64_t lim = (1 << 26) - 1;
    return (int32_t)(w < -lim ? -lim : w > lim ? lim : w);
}

static int32_t half(int32_t d)
{
    return (d + ((d >> 1) & 1)) >> 1;
}

/* The prediction table of proto/CODEC.md for strand j, vertex v, axis a. */
static int32_t predict(const ref_frame *f, uint32_t j, uint32_t v, uint32_t a)
{
    const uint32_t m = f->modes[j];
#define P(i) at(f, f->q, j, (i), a)
#define N(i) at(f, f->q, j - 1u, (i), a)
    if (f->key) {
        if (v == 0) return j ? N(0) : 0;
        if (m == 1 && j) return P(v - 1) + N(v) - N(v - 1);
        if (v == 1) return j ? P(0) + N(1) - N(0) : P(0);
        if (m == 2 && v >= 3) return P(v - 1) + half(P(v - 1) - P(v - 3));
        return 2 * P(v - 1) - P(v - 2);
    }
    if (v == 0) return moved_root(f, j, a) + (j ? N(0) - moved_root(f, j - 1u, a) : 0);
    if (m == 1 && v >= 2) return P(v - 1) + moved_seg(f, j, v, a) + (P(v - 1) - P(v - 2)) - moved_seg(f, j, v - 1u, a);
    if (m == 2 && v >= 2) return 2 * P(v - 1) - P(v - 2);
    if (m == 3 && v == 2) return 2 * P(v - 1) - P(v - 2);
    if (m == 3 && v >= 3) return P(v - 1) + half(P(v - 1) - P(v - 3));
    return P(v - 1) + moved_seg(f, j, v, a);
#undef P
#undef N
}

static uint32_t class_of(uint32_t m)
{
    if (m == 0) return 0;
    if (m >= 32) return 6;
    return 32u - (uint32_t)__builtin_clz(m);
}

/* Builds the frame into out (malloc'd; *len its size). */
static uint8_t *build(const ref_frame *f, size_t *len)
{
    const size_t nsyms = (size_t)f->ns * (1u + f->nv);
    uint16_t *syms = malloc(nsyms * sizeof *syms);
    uint8_t *bits = calloc((size_t)f->ns * f->nv * 3u * 8u + 16u, 1);
    uint32_t *counts = calloc(CODEC_HIST_SIZE, sizeof *counts);
    assert_non_null(syms);
    assert_non_null(bits);
    assert_non_null(counts);
    codec_emitter e = { .syms = syms, .counts = counts, .bits = bits };
    for (uint32_t g = 0; g < f->ns; g += CODEC_LANES) {
        const uint32_t n = f->ns - g < CODEC_LANES ? f->ns - g : CODEC_LANES;
        uint32_t table[CODEC_LANES];
        for (uint32_t l = 0; l < n; l++) {
            codec_emit_symbol(&e, CODEC_T_MODE, f->modes[g + l]);
            table[l] = CODEC_T_ROOT;
        }
        for (uint32_t v = 0; v < f->nv; v++)
            for (uint32_t l = 0; l < n; l++) {
                uint32_t c[3], m[3], sign[3];
                for (uint32_t a = 0; a < 3; a++) {
                    const int32_t r = at(f, f->q, g + l, v, a) - predict(f, g + l, v, a);
                    m[a] = r < 0 ? 0u - (uint32_t)r : (uint32_t)r;
                    sign[a] = r < 0;
                    c[a] = class_of(m[a]);
                }
                codec_emit_symbol(&e, table[l], c[0] + 7u * c[1] + 49u * c[2]);
                for (uint32_t a = 0; a < 3; a++) {
                    if (c[a] >= 1 && c[a] <= 5) codec_emit_bits(&e, sign[a] | (m[a] - (1u << (c[a] - 1u))) << 1, c[a]);
                    if (c[a] == 6) {
                        const uint32_t ex = 31u - (uint32_t)__builtin_clz(m[a]);
                        codec_emit_bits(&e, ex - 5u, 5);
                        codec_emit_bits(&e, sign[a], 1);
                        codec_emit_bits(&e, m[a] - (1u << ex), ex);
                    }
                }
                const uint32_t top = c[0] > c[1] ? (c[0] > c[2] ? c[0] : c[2]) : (c[1] > c[2] ? c[1] : c[2]);
                table[l] = v == 0 ? CODEC_T_FIRST : CODEC_T_BODY + (top < 5 ? top : 5);
            }
    }
    const size_t nbits = (size_t)(codec_emit_finish(&e) - bits);
    assert_int_equal(e.nsyms, nsyms);

    uint16_t freq[CODEC_NTABLES][CODEC_NSYM];
    uint32_t used[CODEC_NTABLES];
    codec_rans_sym *rs = calloc(CODEC_HIST_SIZE, sizeof *rs);
    codec_rans_vsym *vs = calloc(CODEC_HIST_SIZE, sizeof *vs);
    assert_non_null(rs);
    assert_non_null(vs);
    for (uint32_t t = 0; t < CODEC_NTABLES; t++) {
        used[t] = codec_rans_normalize(counts + t * CODEC_NSYM, CODEC_NSYM, freq[t]);
        uint32_t start = 0;
        for (uint32_t s = 0; s < used[t]; s++) {
            if (freq[t][s]) codec_rans_sym_init(&rs[t * CODEC_NSYM + s], &vs[t * CODEC_NSYM + s], start, freq[t][s]);
            start += freq[t][s];
        }
    }
    const size_t cap = 2u * nsyms + 64u;
    uint8_t *rans = malloc(cap);
    assert_non_null(rans);
    const uint32_t tail = f->ns % CODEC_LANES;
    const size_t ntail = (size_t)tail * (1u + f->nv);
    uint32_t x[CODEC_LANES];
    uint8_t *p = codec_rans_encode(syms, nsyms - ntail, ntail, tail, rs, vs, rans + cap, x, true);
    for (int k = CODEC_LANES - 1; k >= 0; k--) {
        p -= 4;
        codec_put_u32(p, x[k]);
    }
    const size_t rlen = (size_t)(rans + cap - p);

    uint8_t *out = calloc(CODEC_HEADER_SIZE + CODEC_MOTION_BYTES + CODEC_NTABLES * 5u * (CODEC_NSYM + 1u) + 4u + rlen + nbits, 1);
    assert_non_null(out);
    uint8_t *w = out + CODEC_HEADER_SIZE;
    if (!f->key) {
        codec_motion_write(w, &f->motion);
        w += CODEC_MOTION_BYTES;
    }
    for (uint32_t t = 0; t < CODEC_NTABLES; t++) w = codec_rans_write_table(w, freq[t], used[t]);
    codec_put_u32(w, (uint32_t)rlen);
    memcpy(w + 4, p, rlen);
    memcpy(w + 4 + rlen, bits, nbits);
    w += 4 + rlen + nbits;
    const size_t payload = (size_t)(w - out) - CODEC_HEADER_SIZE;
    codec_frame_info h = { .seq = f->seq, .ref_seq = f->ref_seq, .sim_time = 0.5, .step = f->step, .max_error_m = f->bound,
                           .keyframe = f->key, .nstrands_total = f->ns, .nstrands_sent = f->ns, .nverts = f->nv,
                           .stride = 1, .payload_len = (uint32_t)payload };
    codec_header_write(out, &h);
    codec_put_u32(out + CODEC_OFF_CRC, codec_frame_crc(out, payload));
    *len = CODEC_HEADER_SIZE + payload;
    free(syms);
    free(bits);
    free(counts);
    free(rs);
    free(vs);
    free(rans);
    return out;
}

static uint32_t rng(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (uint32_t)(*s >> 33);
}

/* Decodes f's frame and requires exactly float32(q step) for every coordinate. */
static void expect_decodes(codec_decoder *dec, const ref_frame *f, const char *what)
{
    size_t len;
    uint8_t *frame = build(f, &len);
    const size_t n = (size_t)f->ns * f->nv * 3u;
    float *out = malloc(n * sizeof *out);
    assert_non_null(out);
    core_err err;
    if (codec_decode(dec, frame, len, out, n, NULL, &err)) fail_msg("%s: %s", what, err.msg);
    for (size_t i = 0; i < n; i++)
        if (out[i] != (float)((double)f->q[i] * f->step))
            fail_msg("%s: coordinate %zu is %.9g, want %.9g", what, i, (double)out[i], (double)f->q[i] * f->step);
    free(out);
    free(frame);
}

static void test_every_mode(void **state)
{
    (void)state;
    const uint32_t shapes[][2] = { { 1, 2 }, { 3, 3 }, { 8, 4 }, { 13, 9 }, { 17, 33 } };
    uint64_t seed = 77;
    for (size_t s = 0; s < sizeof shapes / sizeof shapes[0]; s++) {
        const uint32_t ns = shapes[s][0], nv = shapes[s][1];
        const size_t n = (size_t)ns * nv * 3u;
        int32_t *kq = malloc(n * sizeof *kq), *q = malloc(n * sizeof *q);
        uint32_t *modes = malloc(ns * sizeof *modes);
        assert_non_null(kq);
        assert_non_null(q);
        assert_non_null(modes);
        for (uint32_t j = 0; j < ns; j++) /* strands hanging from a scalp, with a few wild vertices (escapes) */
            for (uint32_t v = 0; v < nv; v++)
                for (uint32_t a = 0; a < 3; a++) {
                    int32_t base = (int32_t)(j * 97u) - 400 + (a == 1 ? -(int32_t)(v * 180u) : (int32_t)(v * 7u * a));
                    kq[((size_t)j * nv + v) * 3u + a] = base + (int32_t)(rng(&seed) % 9u) - 4 +
                                                        (rng(&seed) % 11u == 0 ? (int32_t)(rng(&seed) % 4000u) - 2000 : 0);
                }
        for (uint32_t j = 0; j < ns; j++) modes[j] = j % CODEC_KEY_MODES;
        codec_decoder dec;
        codec_decoder_init(&dec);
        ref_frame key = { .key = true, .seq = 10, .ref_seq = 10, .ns = ns, .nv = nv, .step = 1.9375e-4, .bound = 1e-4f,
                          .q = kq, .modes = modes };
        char what[96];
        snprintf(what, sizeof what, "%u x %u keyframe", ns, nv);
        expect_decodes(&dec, &key, what);
        for (uint32_t m = 0; m < CODEC_DELTA_MODES; m++) {
            for (uint32_t j = 0; j < ns; j++) modes[j] = (j + m) % CODEC_DELTA_MODES;
            for (size_t i = 0; i < n; i++)
                q[i] = kq[i] + (int32_t)(rng(&seed) % 61u) - 30 + (rng(&seed) % 13u == 0 ? (int32_t)(rng(&seed) % 5000u) - 2500 : 0);
            ref_frame d = { .key = false, .seq = 11 + m, .ref_seq = 10, .ns = ns, .nv = nv, .step = 1.9375e-4, .bound = 1e-4f,
                            .q = q, .kq = kq, .modes = modes,
                            .motion = { .rho = { 16380, 300, -200, -300, 16379, 150, 200, -150, 16381 }, .t = { 123, -67, 10 } } };
            snprintf(what, sizeof what, "%u x %u delta, modes from %u", ns, nv, m);
            expect_decodes(&dec, &d, what);
        }
        codec_decoder_free(&dec);
        free(kq);
        free(q);
        free(modes);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_mode),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
