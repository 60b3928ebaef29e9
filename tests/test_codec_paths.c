/* Tests for server/codec's two code paths: the encoder's vector kernels (AVX2 builds) and its
 * portable kernels give the same bytes on every kind of input (partial strand groups, odd and
 * long strands, stride, escapes, keyframes, coordinates that need the careful quantisation),
 * and the folding CRC-32 equals zlib's. In builds without AVX2 both encoders run the portable
 * kernels. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <zlib.h>

#include "bench/codec_synth.h"
#include "codec/codec.h"
#include "codec/codec_core.h"
#include "codec/codec_internal.h"

static uint32_t rng_next(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (uint32_t)(*s >> 33);
}

typedef struct pcase {
    uint32_t nstrands, nverts, stride, key_interval;
    float bound;
    codec_synth_style style;
    int nframes;
    float big;    /* > 0: some coordinates of magnitude in [big / 2, big) (refusals beyond float32's reach) */
    uint32_t one_in; /* how many coordinates per big one */
} pcase;

/* Encodes the case with both paths; every frame must be the same bytes (or the same refusal)
 * and decode within the bound. Returns how many frames were keyframes. */
static int run_case(const pcase *c, uint64_t seed)
{
    codec_desc d = { .max_error_m = c->bound, .key_interval = c->key_interval, .stride = c->stride };
    codec_encoder vec, port;
    codec_decoder dec;
    core_err err;
    assert_int_equal(codec_encoder_init(&vec, &d, c->nstrands, c->nverts, &err), CORE_OK);
    assert_int_equal(codec_encoder_init(&port, &d, c->nstrands, c->nverts, &err), CORE_OK);
    port.portable = true;
    codec_decoder_init(&dec);
    codec_buf a = { 0 }, b = { 0 };
    size_t n = (size_t)c->nstrands * c->nverts * 3u, nsent = (size_t)vec.nstrands_sent * c->nverts * 3u;
    float *in = malloc(n * sizeof *in), *out = malloc(nsent * sizeof *out);
    assert_non_null(in);
    assert_non_null(out);
    int keys = 0, refused = 0;
    for (int f = 0; f < c->nframes; f++) {
        double t = 0.3 + f / 30.0;
        codec_synth_frame(c->nstrands, c->nverts, t, c->style, in);
        if (c->big > 0)
            for (size_t i = 0; i < n; i++)
                if (rng_next(&seed) % c->one_in == 0) {
                    float m = c->big * (0.5f + 0.5f * (float)rng_next(&seed) / 2147483648.0f);
                    in[i] = rng_next(&seed) & 1u ? m : -m;
                }
        bool force = rng_next(&seed) % 11u == 0;
        core_err err2;
        const codec_sim_info snap = codec_synth_sim(t, (uint64_t)f, c->style);
        core_status sa = codec_encode(&vec, in, (uint64_t)f + 1u, &snap, force, &a, &err);
        core_status sb = codec_encode(&port, in, (uint64_t)f + 1u, &snap, force, &b, &err2);
        assert_int_equal(sa, sb);
        assert_int_equal(vec.careful, port.careful);
        if (sa) { /* the same refusal; the encoders go on unchanged */
            assert_int_equal(sa, CORE_EINVAL);
            assert_string_equal(err.msg, err2.msg);
            refused++;
            continue;
        }
        if (a.len != b.len || memcmp(a.data, b.data, a.len) != 0)
            fail_msg("%u x %u stride %u bound %g frame %d: vector and portable paths differ (%zu vs %zu bytes)",
                     c->nstrands, c->nverts, c->stride, (double)c->bound, f, a.len, b.len);
        codec_frame_info info;
        assert_int_equal(codec_decode(&dec, a.data, a.len, out, nsent, &info, &err), CORE_OK);
        keys += info.keyframe;
        for (size_t j = 0, o = 0; j < c->nstrands; j += c->stride)
            for (size_t i = 0; i < (size_t)c->nverts * 3u; i++, o++) {
                float e = out[o] - in[j * c->nverts * 3u + i];
                if (e > c->bound || -e > c->bound) fail_msg("frame %d: error %g over the bound", f, (double)e);
            }
    }
    if (c->big > 0) {
        if (!(refused > 0 && refused < c->nframes)) fail_msg("%d of %d frames refused", refused, c->nframes);
    }
    free(in);
    free(out);
    codec_buf_free(&a);
    codec_buf_free(&b);
    codec_decoder_free(&dec);
    codec_encoder_free(&vec);
    codec_encoder_free(&port);
    return keys;
}

static void test_paths_same_bytes(void **state)
{
    (void)state;
    static const pcase cases[] = {
        { 64, 16, 1, 30, 1e-4f, CODEC_SYNTH_GENTLE, 40, 0, 0 },    /* whole groups */
        { 61, 13, 1, 7, 5e-4f, CODEC_SYNTH_VIOLENT, 30, 0, 0 },    /* a partial group, odd strands */
        { 100, 33, 3, 10, 2e-5f, CODEC_SYNTH_TELEPORT, 40, 0, 0 }, /* stride, escapes, two escape words */
        { 9, 2, 1, 5, 1e-4f, CODEC_SYNTH_VIOLENT, 20, 0, 0 },      /* the shortest strands */
        { 20, 70, 2, 4, 1e-5f, CODEC_SYNTH_TELEPORT, 20, 0, 0 },   /* long strands, finest bound */
        { 24, 12, 1, 6, 1e-5f, CODEC_SYNTH_GENTLE, 40, 60.0f, 30 },     /* float32 cannot hold some */
        { 17, 40, 1, 30, 1e-5f, CODEC_SYNTH_GENTLE, 30, 1500.0f, 900 }, /* out of range */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        assert_true(run_case(&cases[i], 77u + i) >= (cases[i].big > 0 ? 1 : cases[i].nframes / (int)cases[i].key_interval));
}

static void test_crc_matches_zlib(void **state)
{
    (void)state;
    enum { N = 1 << 20 };
    uint8_t *buf = malloc(N);
    assert_non_null(buf);
    uint64_t seed = 5;
    for (size_t i = 0; i < N; i++) buf[i] = (uint8_t)rng_next(&seed);
    for (size_t len = 0; len < 700; len++)
        for (size_t off = 0; off < 4; off++) {
            uint32_t init = off == 0 ? 0 : rng_next(&seed);
            uint32_t want = (uint32_t)crc32(init, buf + off * 17u, (uInt)len);
            if (codec_core_crc32(init, buf + off * 17u, len) != want) fail_msg("CRC differs at length %zu", len);
        }
    assert_int_equal(codec_core_crc32(0, buf, N), (uint32_t)crc32(0, buf, N));
    assert_int_equal(codec_core_crc32(0x12345678u, buf + 3, N - 3), (uint32_t)crc32(0x12345678u, buf + 3, N - 3));
    free(buf);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_paths_same_bytes),
        cmocka_unit_test(test_crc_matches_zlib),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
