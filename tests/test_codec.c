/* Tests for server/codec: error bound on long sequences, skipping decoders, stride, test
 * vectors (bit-exact, regenerated), and rejection of corrupt, truncated and absurd frames.
 * With STRANDCAST_WRITE_VECTORS=1 the vector test rewrites proto/vectors/ instead. */
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

/* ---------------------------------------------------------------- helpers */

static uint32_t rng_next(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (uint32_t)(*s >> 33);
}

static void restamp_crc(uint8_t *frame, size_t len)
{
    uLong c = crc32(0L, Z_NULL, 0);
    c = crc32(c, frame, CODEC_HEADER_SIZE - 4u);
    c = crc32(c, frame + CODEC_HEADER_SIZE, (uInt)(len - CODEC_HEADER_SIZE));
    for (int k = 0; k < 4; k++) frame[CODEC_HEADER_SIZE - 4u + (unsigned)k] = (uint8_t)(c >> (8 * k));
}

static double max_abs_err(const float *a, const float *b, size_t n)
{
    double m = 0;
    for (size_t i = 0; i < n; i++) {
        double e = fabs((double)a[i] - (double)b[i]);
        if (!(e <= m)) m = e;
    }
    return m;
}

/* A snapshot at sim time t (step 0, the gentle animation's head). */
static codec_sim_info at_time(double t)
{
    return codec_synth_sim(t, 0, CODEC_SYNTH_GENTLE);
}

/* codec_encode with the snapshot at_time(t). */
static core_status encode_at(codec_encoder *enc, const float *xyz, uint64_t seq, double t, bool force_key, codec_buf *out,
                             core_err *err)
{
    const codec_sim_info snap = at_time(t);
    return codec_encode(enc, xyz, seq, &snap, force_key, out, err);
}

/* The input positions of the strands a frame at `stride` sends. */
static void gather(const float *all, uint32_t nstrands, uint32_t nverts, uint32_t stride, float *out)
{
    size_t per = (size_t)nverts * 3u, o = 0;
    for (uint32_t s = 0; s < nstrands; s += stride, o += per) memcpy(out + o, all + (size_t)s * per, per * sizeof *out);
}

/* ---------------------------------------------------------------- error bound on sequences */

/* Encodes nframes of a synthetic animation; decoder A takes every frame, decoder B a random
 * subset (always keyframes); both must give identical positions within the bound. */
static void run_sequence(float bound, codec_synth_style style, uint32_t stride, uint32_t key_interval,
                         uint32_t nstrands, uint32_t nverts, int nframes, uint64_t seed)
{
    codec_desc d = { .max_error_m = bound, .key_interval = key_interval, .stride = stride };
    codec_encoder enc;
    core_err err;
    assert_int_equal(codec_encoder_init(&enc, &d, nstrands, nverts, &err), CORE_OK);
    codec_decoder all, some;
    codec_decoder_init(&all);
    codec_decoder_init(&some);
    codec_buf buf = { 0 };
    size_t n = (size_t)nstrands * nverts * 3u, nsent = (size_t)enc.nstrands_sent * nverts * 3u;
    float *in = malloc(n * sizeof *in), *want = malloc(nsent * sizeof *want);
    float *outa = malloc(nsent * sizeof *outa), *outb = malloc(nsent * sizeof *outb);
    assert_non_null(in);
    assert_non_null(want);
    assert_non_null(outa);
    assert_non_null(outb);
    double worst = 0;
    int keys = 0, skipped = 0;
    for (int f = 0; f < nframes; f++) {
        double t = f / 60.0;
        codec_synth_frame(nstrands, nverts, t, style, in);
        bool force = (rng_next(&seed) % 23u) == 0;
        const codec_sim_info snap = codec_synth_sim(t, (uint64_t)f * 3u, style);
        assert_int_equal(codec_encode(&enc, in, (uint64_t)f + 100u, &snap, force, &buf, &err), CORE_OK);
        gather(in, nstrands, nverts, stride, want);
        codec_frame_info ia, ib;
        core_status st = codec_decode(&all, buf.data, buf.len, outa, nsent, &ia, &err);
        if (st) fail_msg("decode frame %d: %s", f, err.msg);
        assert_true(ia.seq == (uint64_t)f + 100u && ia.sim.sim_time == t && ia.sim.sim_step == (uint64_t)f * 3u);
        assert_memory_equal(ia.sim.head_pos, snap.head_pos, sizeof snap.head_pos); /* the header carries them */
        assert_memory_equal(ia.sim.head_rot, snap.head_rot, sizeof snap.head_rot);
        assert_int_equal(ia.nstrands_sent, enc.nstrands_sent);
        keys += ia.keyframe;
        if (force) assert_true(ia.keyframe);
        double e = max_abs_err(want, outa, nsent);
        if (e > (double)bound) fail_msg("frame %d: error %.9g exceeds bound %.9g", f, e, (double)bound);
        if (e > worst) worst = e;
        if (ia.keyframe || rng_next(&seed) % 3u == 0) {
            assert_int_equal(codec_decode(&some, buf.data, buf.len, outb, nsent, &ib, &err), CORE_OK);
            assert_memory_equal(outa, outb, nsent * sizeof *outa);
        } else {
            skipped++;
        }
    }
    assert_true(keys >= nframes / (int)key_interval);
    assert_true(skipped > 0);
    assert_true(worst > 0.2 * (double)bound); /* the bound is used, not trivially met */
    free(in);
    free(want);
    free(outa);
    free(outb);
    codec_buf_free(&buf);
    codec_decoder_free(&all);
    codec_decoder_free(&some);
    codec_encoder_free(&enc);
}

static void test_bound_all_styles(void **state)
{
    (void)state;
    const float bounds[3] = { 5e-4f, 1e-4f, 2e-5f };
    for (int b = 0; b < 3; b++) {
        run_sequence(bounds[b], CODEC_SYNTH_GENTLE, 1, 30, 64, 16, 120, 1u + (uint64_t)b);
        run_sequence(bounds[b], CODEC_SYNTH_VIOLENT, 1, 30, 64, 16, 120, 11u + (uint64_t)b);
        run_sequence(bounds[b], CODEC_SYNTH_TELEPORT, 1, 30, 64, 16, 150, 21u + (uint64_t)b);
        run_sequence(bounds[b], CODEC_SYNTH_VIOLENT, 3, 10, 100, 24, 90, 31u + (uint64_t)b);
    }
    /* 2101 strands: the motion is estimated from every other root, a partial last group */
    run_sequence(1e-4f, CODEC_SYNTH_VIOLENT, 1, 30, 2101, 5, 16, 41u);
}

/* An encoder (for ns x nv vertices, desc d) and a decoder, for a round-trip test. */
static void pair_open(codec_encoder *enc, codec_decoder *dec, const codec_desc *d, uint32_t ns, uint32_t nv)
{
    core_err err;
    assert_int_equal(codec_encoder_init(enc, d, ns, nv, &err), CORE_OK);
    codec_decoder_init(dec);
}

/* Frees what pair_open made and the frame buffer. */
static void pair_close(codec_encoder *enc, codec_decoder *dec, codec_buf *buf)
{
    codec_buf_free(buf);
    codec_decoder_free(dec);
    codec_encoder_free(enc);
}

/* Resets: positions jump between unrelated poses (rest pose vs. swung far away) mid-GOP. */
static void test_bound_resets(void **state)
{
    (void)state;
    const uint32_t ns = 50, nv = 20;
    size_t n = (size_t)ns * nv * 3u;
    float *in = malloc(n * sizeof *in), *out = malloc(n * sizeof *out);
    codec_desc d = { .max_error_m = 2e-5f, .key_interval = 1000 };
    codec_encoder enc;
    codec_decoder dec;
    core_err err;
    codec_buf buf = { 0 };
    pair_open(&enc, &dec, &d, ns, nv);
    for (int f = 0; f < 40; f++) {
        double t = (f % 2) ? 0.0 : 7.3 + f;
        codec_synth_frame(ns, nv, t, (f % 3) ? CODEC_SYNTH_VIOLENT : CODEC_SYNTH_TELEPORT, in);
        assert_int_equal(encode_at(&enc, in, (uint64_t)f, t, false, &buf, &err), CORE_OK);
        codec_frame_info info;
        assert_int_equal(codec_decode(&dec, buf.data, buf.len, out, n, &info, &err), CORE_OK);
        assert_true(info.keyframe == (f == 0));
        assert_true(max_abs_err(in, out, n) <= 2e-5);
    }
    free(in);
    free(out);
    pair_close(&enc, &dec, &buf);
}

/* Coordinates near float32 rounding limits and at several magnitudes still meet the bound. */
static void test_bound_magnitudes(void **state)
{
    (void)state;
    const uint32_t ns = 7, nv = 5;
    size_t n = (size_t)ns * nv * 3u;
    float in[7 * 5 * 3], out[7 * 5 * 3];
    uint64_t seed = 99;
    for (int b = 0; b < 3; b++) {
        const float bound = b == 0 ? 1e-5f : b == 1 ? 2e-5f : 0.1f;
        codec_desc d = { .max_error_m = bound };
        codec_encoder enc;
        codec_decoder dec;
        core_err err;
        codec_buf buf = { 0 };
        pair_open(&enc, &dec, &d, ns, nv);
        for (int f = 0; f < 50; f++) {
            float scale = (float)(1u << (f % 4));
            for (size_t i = 0; i < n; i++)
                in[i] = scale * ((float)rng_next(&seed) / 4294967296.0f - 0.5f) + (float)(i % 3) * 0.25f;
            assert_int_equal(encode_at(&enc, in, (uint64_t)f, 0.0, false, &buf, &err), CORE_OK);
            assert_int_equal(codec_decode(&dec, buf.data, buf.len, out, n, NULL, &err), CORE_OK);
            assert_true(max_abs_err(in, out, n) <= (double)bound);
        }
        pair_close(&enc, &dec, &buf);
    }
}

/* Keyframe segments longer than 32767 lattice units (clamped before the rotation in deltas) and
 * a rotating head: deltas still meet the bound, in a frame with a partial group of 8. */
static void test_bound_long_segments(void **state)
{
    (void)state;
    const uint32_t ns = 11, nv = 6;
    size_t n = (size_t)ns * nv * 3u;
    float base[11 * 6 * 3], in[11 * 6 * 3], out[11 * 6 * 3];
    const float bound = 1e-5f;
    const double step = 2.0 * (double)bound * (1.0 - 1.0 / 32.0);
    for (uint32_t j = 0; j < ns; j++)
        for (uint32_t v = 0; v < nv; v++) {
            float *p = base + 3u * (j * nv + v);
            p[0] = 0.01f * (float)j + 0.002f * (float)v;
            p[1] = 0.05f - 0.004f * (float)v;
            p[2] = 0.003f * (float)(j % 3);
            if (v >= 3) p[0] += (j % 2) ? 1.5f : -1.2f; /* segment 2 -> 3: over 60000 units */
            if (v >= 5) p[2] -= 0.9f;
        }
    assert_true(fabs((double)(base[3 * 3] - base[3 * 2])) / step > 32767.0);
    codec_desc d = { .max_error_m = bound, .key_interval = 1000 };
    codec_encoder enc;
    codec_decoder dec;
    core_err err;
    codec_buf buf = { 0 };
    pair_open(&enc, &dec, &d, ns, nv);
    for (int f = 0; f < 12; f++) {
        double a = 0.07 * f, c = cos(a), s = sin(a);
        for (size_t i = 0; i < n; i += 3) { /* rotate about z, translate, a little wobble */
            double x = base[i], y = base[i + 1], z = base[i + 2];
            in[i] = (float)(c * x - s * y + 0.01 * f);
            in[i + 1] = (float)(s * x + c * y - 0.002 * f);
            in[i + 2] = (float)(z + 1e-4 * sin(0.37 * (double)i + f));
        }
        assert_int_equal(encode_at(&enc, in, (uint64_t)f + 1u, 0.0, false, &buf, &err), CORE_OK);
        codec_frame_info info;
        assert_int_equal(codec_decode(&dec, buf.data, buf.len, out, n, &info, &err), CORE_OK);
        assert_true(info.keyframe == (f == 0));
        if (max_abs_err(in, out, n) > (double)bound) fail_msg("frame %d: error %g", f, max_abs_err(in, out, n));
    }
    pair_close(&enc, &dec, &buf);
}

/* Far from the origin float32 cannot hold every coordinate within a small bound: such a
 * coordinate is refused (the magnitude shortcut of the quantiser must not skip the check). */
static void test_bound_float32_reach(void **state)
{
    (void)state;
    const uint32_t ns = 9, nv = 3;
    float in[9 * 3 * 3], out[9 * 3 * 3];
    const float bound = 1e-5f;
    codec_desc d = { .max_error_m = bound };
    codec_encoder enc;
    codec_decoder dec;
    core_err err;
    codec_buf buf = { 0 };
    pair_open(&enc, &dec, &d, ns, nv);
    for (uint32_t i = 0; i < ns * nv * 3u; i++) in[i] = 0.3f + 0.001f * (float)i;
    /* 3 m and 300 m are beyond the shortcut's 2^18 bound = 2.6 m but reachable */
    in[40] = 3.0f;
    in[41] = -300.0f;
    assert_int_equal(encode_at(&enc, in, 1, 0.0, false, &buf, &err), CORE_OK);
    assert_int_equal(codec_decode(&dec, buf.data, buf.len, out, ns * nv * 3u, NULL, &err), CORE_OK);
    assert_true(max_abs_err(in, out, ns * nv * 3u) <= (double)bound);
    /* at 200 m float32's spacing is 1.5e-5 m: a value about halfway between two lattice points
     * has no lattice point whose float32 is within 1e-5 */
    uint32_t refused = 0;
    const int tries = 3000;
    for (int k = 0; k < tries; k++) {
        in[40] = nextafterf(in[40] == 3.0f ? 200.0f : in[40], 30.0f); /* consecutive float32 values */
        core_status st = encode_at(&enc, in, 2u + (uint64_t)k, 0.0, false, &buf, &err);
        if (st != CORE_OK) {
            assert_int_equal(st, CORE_EINVAL);
            assert_non_null(strstr(err.msg, "cannot be held"));
            refused++;
            continue;
        }
        assert_int_equal(codec_decode(&dec, buf.data, buf.len, out, ns * nv * 3u, NULL, &err), CORE_OK);
        assert_true(max_abs_err(in, out, ns * nv * 3u) <= (double)bound);
    }
    assert_true(refused > 0 && refused < (uint32_t)tries / 2u);
    pair_close(&enc, &dec, &buf);
}

/* ---------------------------------------------------------------- encoder argument checks */

static void test_encoder_rejects(void **state)
{
    (void)state;
    codec_encoder enc;
    core_err err;
    codec_desc bad = { .max_error_m = 0.5f };
    assert_int_equal(codec_encoder_init(&enc, &bad, 4, 4, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "max_error_m"));
    assert_int_equal(codec_encoder_init(&enc, NULL, 4, 1, &err), CORE_EINVAL);
    assert_int_equal(codec_encoder_init(&enc, NULL, 0, 4, &err), CORE_EINVAL);
    assert_int_equal(codec_encoder_init(&enc, NULL, 1u << 20, 4096, &err), CORE_EINVAL);
    assert_int_equal(codec_encoder_init(&enc, NULL, 3, 4, &err), CORE_OK);
    float xyz[36];
    codec_buf buf = { 0 };
    for (int i = 0; i < 36; i++) xyz[i] = 0.01f * (float)i;
    xyz[17] = NAN;
    assert_int_equal(encode_at(&enc, xyz, 1, 0.0, false, &buf, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "not finite"));
    xyz[17] = 1e9f;
    assert_int_equal(encode_at(&enc, xyz, 1, 0.0, false, &buf, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "out of range"));
    xyz[17] = 0.5f;
    assert_int_equal(encode_at(&enc, xyz, 5, 0.0, false, &buf, &err), CORE_OK);
    assert_int_equal(encode_at(&enc, xyz, 5, 0.0, false, &buf, &err), CORE_EINVAL);
    assert_int_equal(encode_at(&enc, xyz, 6, NAN, false, &buf, &err), CORE_EINVAL);
    assert_int_equal(encode_at(&enc, xyz, 6, 0.1, false, &buf, &err), CORE_OK);
    codec_buf_free(&buf);
    codec_encoder_free(&enc);
    codec_encoder_free(&enc); /* safe twice */
}

/* ---------------------------------------------------------------- corrupt frames */

typedef struct frames3 {
    codec_buf key, delta, key2;
    float *want;
    size_t n;
} frames3;

/* A keyframe, a delta against it, and a later keyframe (24 strands x 12 vertices). */
static void make_frames(frames3 *f)
{
    const uint32_t ns = 24, nv = 12;
    memset(f, 0, sizeof *f);
    f->n = (size_t)ns * nv * 3u;
    f->want = malloc(f->n * sizeof *f->want);
    codec_encoder enc;
    core_err err;
    codec_desc d = { .key_interval = 100 };
    assert_int_equal(codec_encoder_init(&enc, &d, ns, nv, &err), CORE_OK);
    codec_synth_frame(ns, nv, 0.0, CODEC_SYNTH_VIOLENT, f->want);
    assert_int_equal(encode_at(&enc, f->want, 1, 0.0, false, &f->key, &err), CORE_OK);
    codec_synth_frame(ns, nv, 1.1, CODEC_SYNTH_TELEPORT, f->want); /* large residuals: escapes */
    assert_int_equal(encode_at(&enc, f->want, 2, 0.5, false, &f->delta, &err), CORE_OK);
    assert_int_equal(encode_at(&enc, f->want, 3, 0.6, true, &f->key2, &err), CORE_OK);
    codec_encoder_free(&enc);
}

static void free_frames(frames3 *f)
{
    codec_buf_free(&f->key);
    codec_buf_free(&f->delta);
    codec_buf_free(&f->key2);
    free(f->want);
}

static void test_reference_rules(void **state)
{
    (void)state;
    frames3 f;
    make_frames(&f);
    float *out = malloc(f.n * sizeof *out);
    codec_decoder dec;
    core_err err;
    codec_frame_info info;
    codec_decoder_init(&dec);
    assert_int_equal(codec_decode(&dec, f.delta.data, f.delta.len, out, f.n, NULL, &err), CORE_ESTATE);
    assert_non_null(strstr(err.msg, "keyframe 1"));
    assert_int_equal(codec_decode(&dec, f.key.data, f.key.len, out, f.n - 1, NULL, &err), CORE_EINVAL);
    assert_int_equal(codec_decode(&dec, f.key.data, f.key.len, out, f.n, &info, &err), CORE_OK);
    assert_true(info.keyframe && info.seq == 1 && info.ref_seq == 1);
    assert_int_equal(codec_decode(&dec, f.delta.data, f.delta.len, out, f.n, &info, &err), CORE_OK);
    assert_true(!info.keyframe && info.seq == 2 && info.ref_seq == 1);
    assert_true(max_abs_err(out, f.want, f.n) <= 1e-4);
    assert_int_equal(codec_decode(&dec, f.key2.data, f.key2.len, out, f.n, &info, &err), CORE_OK);
    assert_true(max_abs_err(out, f.want, f.n) <= 1e-4);
    /* the old delta's keyframe has been replaced */
    assert_int_equal(codec_decode(&dec, f.delta.data, f.delta.len, out, f.n, NULL, &err), CORE_ESTATE);
    /* a failed keyframe leaves the held one intact */
    f.key.data[f.key.len - 1] ^= 0x10;
    assert_int_equal(codec_decode(&dec, f.key.data, f.key.len, out, f.n, NULL, &err), CORE_EFORMAT);
    f.key.data[f.key.len - 1] ^= 0x10;
    assert_int_equal(codec_decode(&dec, f.key.data, f.key.len, out, f.n, NULL, &err), CORE_OK);
    assert_int_equal(codec_decode(&dec, f.delta.data, f.delta.len, out, f.n, NULL, &err), CORE_OK);
    assert_true(max_abs_err(out, f.want, f.n) <= 1e-4);
    free(out);
    codec_decoder_free(&dec);
    free_frames(&f);
}

/* Decoding must fail cleanly and leave the output untouched. */
static void expect_reject(codec_decoder *dec, const uint8_t *data, size_t len, float *out, size_t n,
                          core_status want)
{
    core_err err = { { 0 } };
    for (size_t i = 0; i < n; i++) out[i] = -7.0f;
    core_status st = codec_decode(dec, data, len, out, n, NULL, &err);
    if (st != want) fail_msg("status %d, wanted %d (%s)", (int)st, (int)want, err.msg);
    assert_true(strncmp(err.msg, "codec: ", 7) == 0);
    for (size_t i = 0; i < n; i++) assert_true(out[i] == -7.0f);
}

static void test_truncated_prefixes(void **state)
{
    (void)state;
    frames3 f;
    make_frames(&f);
    float *out = malloc(f.n * sizeof *out);
    codec_decoder dec;
    core_err err;
    codec_decoder_init(&dec);
    const codec_buf *fr[2] = { &f.key, &f.delta };
    for (int k = 0; k < 2; k++) {
        for (size_t len = 0; len < fr[k]->len; len++) {
            uint8_t *copy = malloc(len ? len : 1); /* exact size: ASan sees any overread */
            memcpy(copy, fr[k]->data, len);
            expect_reject(&dec, copy, len, out, f.n, CORE_EFORMAT);
            /* the same prefix claiming to be complete (payload length and CRC fixed up) */
            if (len > CODEC_HEADER_SIZE) {
                for (int b = 0; b < 4; b++) copy[60 + b] = (uint8_t)((len - CODEC_HEADER_SIZE) >> (8 * b));
                restamp_crc(copy, len);
                expect_reject(&dec, copy, len, out, f.n, CORE_EFORMAT);
            }
            free(copy);
        }
        if (k == 0) assert_int_equal(codec_decode(&dec, f.key.data, f.key.len, out, f.n, NULL, &err), CORE_OK);
    }
    free(out);
    codec_decoder_free(&dec);
    free_frames(&f);
}

static void test_bit_flips(void **state)
{
    (void)state;
    frames3 f;
    make_frames(&f);
    float *out = malloc(f.n * sizeof *out);
    codec_decoder dec;
    core_err err;
    codec_decoder_init(&dec);
    uint64_t seed = 12345;
    int deep_rejects = 0, deep_ok = 0;
    const codec_buf *fr[2] = { &f.key, &f.delta };
    for (int k = 0; k < 2; k++) {
        uint8_t *copy = malloc(fr[k]->len);
        for (int trial = 0; trial < 600; trial++) {
            memcpy(copy, fr[k]->data, fr[k]->len);
            int flips = 1 + (int)(rng_next(&seed) % 3u);
            for (int b = 0; b < flips; b++) {
                uint32_t bit = rng_next(&seed) % (uint32_t)(fr[k]->len * 8u);
                copy[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
            }
            if (memcmp(copy, fr[k]->data, fr[k]->len) == 0) continue;
            expect_reject(&dec, copy, fr[k]->len, out, f.n, CORE_EFORMAT);
            /* Past the CRC: payload damage must be caught by the format checks or decode
             * to finite, in-range values without touching memory it should not. */
            if (trial % 2 == 0) {
                memcpy(copy, fr[k]->data, fr[k]->len);
                uint32_t bit = CODEC_HEADER_SIZE * 8u + rng_next(&seed) % (uint32_t)((fr[k]->len - CODEC_HEADER_SIZE) * 8u);
                copy[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
                restamp_crc(copy, fr[k]->len);
                if (codec_decode(&dec, copy, fr[k]->len, out, f.n, NULL, &err) == CORE_OK) {
                    deep_ok++;
                    for (size_t i = 0; i < f.n; i++) assert_true(isfinite(out[i]) && fabsf(out[i]) < 1e4f);
                    if (k == 0) /* a damaged keyframe was taken: restore the real one */
                        assert_int_equal(codec_decode(&dec, f.key.data, f.key.len, out, f.n, NULL, &err), CORE_OK);
                } else {
                    deep_rejects++;
                }
            }
        }
        free(copy);
        if (k == 0) assert_int_equal(codec_decode(&dec, f.key.data, f.key.len, out, f.n, NULL, &err), CORE_OK);
    }
    /* flips in the entropy-coded part break its end-state checks; flips in raw sign and
     * mantissa bits decode to other in-range values (only the CRC can catch those) */
    print_message("payload bit flips past the CRC: %d rejected, %d decoded\n", deep_rejects, deep_ok);
    assert_true(deep_rejects > deep_ok / 4);
    free(out);
    codec_decoder_free(&dec);
    free_frames(&f);
}

static void put32(uint8_t *p, uint32_t v)
{
    for (int k = 0; k < 4; k++) p[k] = (uint8_t)(v >> (8 * k));
}

static void put64(uint8_t *p, uint64_t v)
{
    for (int k = 0; k < 8; k++) p[k] = (uint8_t)(v >> (8 * k));
}

static void test_absurd_headers(void **state)
{
    (void)state;
    frames3 f;
    make_frames(&f);
    float *out = malloc(f.n * sizeof *out);
    codec_decoder dec;
    codec_decoder_init(&dec);
    uint8_t *c = malloc(f.key.len);
    const double nan = NAN, huge = 1e300, zero = 0.0;
    float fnan = NAN;
    uint64_t u;
    uint32_t u32;
    for (int which = 0; which < 27; which++) {
        memcpy(c, f.key.data, f.key.len);
        switch (which) {
        case 0: c[0] = 'X'; break;
        case 1: c[4] = 2; break;                               /* a version 2 frame */
        case 2: c[6] = 9; break;
        case 3: c[7] = 0x81; break;
        case 4: put64(c + 16, 0); break;                       /* keyframe ref != seq */
        case 5: c[7] = 0; break;                               /* delta with ref == seq */
        case 6: memcpy(&u, &nan, 8); put64(c + 24, u); break;  /* sim time */
        case 7: memcpy(&u, &nan, 8); put64(c + 32, u); break;  /* step */
        case 8: memcpy(&u, &zero, 8); put64(c + 32, u); break;
        case 9: memcpy(&u, &huge, 8); put64(c + 32, u); break;
        case 10: memcpy(&u32, &fnan, 4); put32(c + 40, u32); break;
        case 11: put32(c + 40, 0x7f800000u); break;            /* bound = inf */
        case 12: put32(c + 44, 0); break;                      /* total strands */
        case 13: put32(c + 44, 0xffffffffu); break;
        case 14: put32(c + 48, 0); break;                      /* sent */
        case 15: put32(c + 48, 25); break;
        case 16: put32(c + 52, 0); break;                      /* nverts */
        case 17: put32(c + 52, 1); break;
        case 18: put32(c + 52, 0xffffffffu); break;
        case 19: put32(c + 56, 0); break;                      /* stride */
        case 20: put32(c + 56, 0xffffffffu); break;
        case 21: put32(c + 60, 0xffffffffu); break;            /* payload length */
        case 22: put32(c + 60, 0); break;
        case 23: put32(c + 44, 1u << 24); put32(c + 48, 1u << 24); break; /* too many vertices */
        case 24: put32(c + 52, 11); break;                     /* layout vs payload */
        case 25: put32(c + 44, 23); put32(c + 48, 23); break;
        case 26: c[CODEC_HEADER_SIZE + 4] ^= 0xff; break;      /* tables */
        }
        restamp_crc(c, f.key.len);
        expect_reject(&dec, c, f.key.len, out, f.n, CORE_EFORMAT);
        codec_frame_info info;
        core_err err;
        if (which < 24) assert_int_equal(codec_peek_header(c, f.key.len, &info, &err), CORE_EFORMAT);
    }
    free(c);
    /* a delta whose rigid motion is out of range or has nonzero padding */
    core_err err;
    assert_int_equal(codec_decode(&dec, f.key.data, f.key.len, out, f.n, NULL, &err), CORE_OK);
    c = malloc(f.delta.len);
    uint8_t *m = c + CODEC_HEADER_SIZE;
    for (int k = 0; k < 8; k++) {
        memcpy(c, f.delta.data, f.delta.len);
        switch (k) {
        case 0: m[0] = 0x01; m[1] = 0x40; break;               /* rho_0 = 16385 */
        case 1: m[8] = 0xff; m[9] = 0xbf; break;               /* rho_4 = -16385 */
        case 2: m[16] = 0x00; m[17] = 0x80; break;             /* rho_8 = -32768 */
        case 3: m[18] = 1; break;                              /* padding after rho */
        case 4: m[47] = 0x80; break;                           /* trailing padding */
        case 5: put32(m + 20, (1u << 28) + 1u); break;         /* t_0 */
        case 6: put32(m + 28, (uint32_t)-(1 << 28) - 1u); break; /* t_2 */
        case 7: m[35] = 2; break;
        }
        restamp_crc(c, f.delta.len);
        expect_reject(&dec, c, f.delta.len, out, f.n, CORE_EFORMAT);
        assert_int_equal(codec_decode(&dec, c, f.delta.len, out, f.n, NULL, &err), CORE_EFORMAT);
        assert_non_null(strstr(err.msg, "motion"));
    }
    /* the extremes of the ranges are valid */
    memcpy(c, f.delta.data, f.delta.len);
    put32(m + 20, 1u << 28);
    put32(m + 24, (uint32_t)-(1 << 28));
    m[0] = 0x00; m[1] = 0x40;
    m[2] = 0x00; m[3] = 0xc0;
    restamp_crc(c, f.delta.len);
    if (codec_decode(&dec, c, f.delta.len, out, f.n, NULL, &err) != CORE_OK) assert_null(strstr(err.msg, "motion"));
    assert_int_equal(codec_decode(&dec, f.delta.data, f.delta.len, out, f.n, NULL, &err), CORE_OK);
    free(c);
    free(out);
    codec_decoder_free(&dec);
    free_frames(&f);
}

/* A header whose simulation snapshot is bad: a non-finite head position or rotation, a rotation
 * that is not a unit quaternion; each refused by the decoder and by codec_peek_header with a
 * message naming it, and never written by the encoder. The tolerance's edges are accepted. */
static void test_bad_head(void **state)
{
    (void)state;
    frames3 f;
    make_frames(&f);
    float *out = malloc(f.n * sizeof *out);
    codec_decoder dec;
    codec_decoder_init(&dec);
    core_err err;
    codec_frame_info info;
    uint8_t *c = malloc(f.key.len);
    const float fnan = NAN, finf = INFINITY, half = 0.5f, tiny = 0.9999f, slightly = 1.00004f;
    const float *vals[] = { &fnan, &finf, &fnan, &finf, &half, &tiny };
    const size_t offs[] = { 72, 80, 84, 96, 96, 96 }; /* head x, z; rotation x, w */
    const char *want[] = { "head position is not finite [head, byte 72]", "head position is not finite [head, byte 80]",
                           "head rotation is not finite [head, byte 84]", "head rotation is not finite [head, byte 96]",
                           "not a unit quaternion (squared norm 0.25", "not a unit quaternion (squared norm 0.9997" };
    for (size_t k = 0; k < sizeof offs / sizeof offs[0]; k++) {
        memcpy(c, f.key.data, f.key.len);
        uint32_t u;
        memcpy(&u, vals[k], 4);
        put32(c + offs[k], u);
        if (offs[k] == 96) memset(c + 84, 0, 12); /* the rotation (0, 0, 0, w) */
        restamp_crc(c, f.key.len);
        expect_reject(&dec, c, f.key.len, out, f.n, CORE_EFORMAT);
        assert_int_equal(codec_decode(&dec, c, f.key.len, out, f.n, NULL, &err), CORE_EFORMAT);
        if (!strstr(err.msg, want[k])) fail_msg("case %zu: '%s' does not say '%s'", k, err.msg, want[k]);
        assert_int_equal(codec_peek_header(c, f.key.len, &info, &err), CORE_EFORMAT);
        assert_non_null(strstr(err.msg, "head"));
    }
    /* (0, 0, 0, 1.00004): squared norm 1.00008, within 1e-4 */
    memcpy(c, f.key.data, f.key.len);
    memset(c + 84, 0, 12);
    uint32_t u;
    memcpy(&u, &slightly, 4);
    put32(c + 96, u);
    restamp_crc(c, f.key.len);
    assert_int_equal(codec_decode(&dec, c, f.key.len, out, f.n, &info, &err), CORE_OK);
    assert_true(info.sim.head_rot[3] == slightly && info.sim.head_rot[0] == 0.0f);
    free(c);

    /* the encoder refuses to write such a header (and stays usable) */
    codec_encoder enc;
    codec_buf buf = { 0 };
    assert_int_equal(codec_encoder_init(&enc, NULL, 24, 12, &err), CORE_OK);
    codec_sim_info s = at_time(0.25);
    s.head_pos[1] = NAN;
    assert_int_equal(codec_encode(&enc, f.want, 1, &s, false, &buf, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "head position is not finite"));
    s = at_time(0.25);
    s.head_rot[3] = INFINITY;
    assert_int_equal(codec_encode(&enc, f.want, 1, &s, false, &buf, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "head rotation is not finite"));
    s = at_time(0.25);
    for (int i = 0; i < 4; i++) s.head_rot[i] *= 1.01f;
    assert_int_equal(codec_encode(&enc, f.want, 1, &s, false, &buf, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "unit quaternion"));
    assert_int_equal(codec_encode(&enc, f.want, 1, NULL, false, &buf, &err), CORE_EINVAL);
    s = at_time(0.25);
    s.sim_step = UINT64_MAX;
    assert_int_equal(codec_encode(&enc, f.want, 1, &s, false, &buf, &err), CORE_OK);
    assert_int_equal(codec_decode(&dec, buf.data, buf.len, out, f.n, &info, &err), CORE_OK);
    assert_true(info.sim.sim_step == UINT64_MAX && info.sim.sim_time == 0.25);
    assert_memory_equal(info.sim.head_rot, s.head_rot, sizeof s.head_rot);
    codec_buf_free(&buf);
    codec_encoder_free(&enc);
    free(out);
    codec_decoder_free(&dec);
    free_frames(&f);
}

/* Offset in a frame of rans_len (after the motion and the nine tables). */
static size_t rans_len_offset(const uint8_t *frame)
{
    size_t pos = CODEC_HEADER_SIZE + ((frame[7] & 1u) ? 0u : 48u);
    for (int t = 0; t < 9; t++) {
        uint32_t vals[2], count = 0; /* the count, then gap and frequency pairs */
        for (int b = 0; b < 2; b++) {
            count |= (uint32_t)(frame[pos] & 0x7fu) << (7 * b);
            if (!(frame[pos++] & 0x80u)) break;
        }
        for (uint32_t i = 0; i < 2u * count; i++) {
            vals[i & 1u] = 0;
            for (int b = 0; b < 2; b++) {
                vals[i & 1u] |= (uint32_t)(frame[pos] & 0x7fu) << (7 * b);
                if (!(frame[pos++] & 0x80u)) break;
            }
        }
    }
    return pos;
}

static uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* Offset in a frame of the raw bit stream. */
static size_t rl_bits_offset(const uint8_t *frame)
{
    size_t rl = rans_len_offset(frame);
    return rl + 4u + get32(frame + rl);
}

/* Frames of format version 2 and entropy streams that break the format's rules are refused. */
static void test_v2_rejections(void **state)
{
    (void)state;
    frames3 f;
    make_frames(&f);
    float *out = malloc(f.n * sizeof *out);
    codec_decoder dec;
    codec_decoder_init(&dec);
    core_err err;
    uint8_t *c = malloc(f.key.len);
    const size_t rl = rans_len_offset(f.key.data);
    const uint32_t rans_len = get32(f.key.data + rl);
    assert_true(rans_len >= 32 && rans_len % 2 == 0 && rl + 4 + rans_len <= f.key.len);
    for (int k = 0; k < 9; k++) {
        memcpy(c, f.key.data, f.key.len);
        const char *want = "entropy";
        switch (k) {
        case 0: c[4] = 2; want = "unsupported format version 2 (this decoder reads 3) [version, byte 4]"; break;
        case 1: put32(c + rl + 4 + 12, 0xffffu); want = "state 65535 in lane 3"; break; /* x[3] below 2^16 */
        case 2: put32(c + rl + 4, 0); want = "state"; break;             /* x[0] = 0 */
        case 3: put32(c + rl, rans_len - 1u); want = "[rans_len, byte"; break; /* odd */
        case 4: put32(c + rl, 30); break;                                /* shorter than the states */
        case 5: put32(c + rl, rans_len - 2u); want = "codec: "; break;   /* a word short */
        case 6: put32(c + rl, rans_len + 2u); want = "codec: "; break;   /* an unused word */
        case 7: put32(c + rl + 4 + 28, get32(c + rl + 4 + 28) ^ 0x100u); want = "codec: "; break;
        case 8: put32(c + rl, (uint32_t)(f.key.len - rl - 3u)); break;   /* past the payload */
        }
        restamp_crc(c, f.key.len);
        expect_reject(&dec, c, f.key.len, out, f.n, CORE_EFORMAT);
        assert_int_equal(codec_decode(&dec, c, f.key.len, out, f.n, NULL, &err), CORE_EFORMAT);
        if (!strstr(err.msg, want)) fail_msg("case %d: '%s' does not say '%s'", k, err.msg, want);
    }
    assert_int_equal(codec_decode(&dec, f.key.data, f.key.len, out, f.n, NULL, &err), CORE_OK);
    free(c);

    /* an escaped root: its first raw bits are 5 bits of e - 5; above 24 is refused */
    const uint32_t ns = 8, nv = 4;
    float in[8 * 4 * 3], got[8 * 4 * 3];
    for (uint32_t i = 0; i < ns * nv * 3u; i++) in[i] = 0.75f + 0.001f * (float)i;
    codec_encoder enc;
    codec_buf buf = { 0 };
    assert_int_equal(codec_encoder_init(&enc, NULL, ns, nv, &err), CORE_OK);
    assert_int_equal(encode_at(&enc, in, 1, 0.0, false, &buf, &err), CORE_OK);
    codec_decoder d2;
    codec_decoder_init(&d2);
    assert_int_equal(codec_decode(&d2, buf.data, buf.len, got, ns * nv * 3u, NULL, &err), CORE_OK);
    /* strand 0's root x is predicted by 0: q = round(0.75 / step), e = floor(log2 q) */
    const double step = 2.0 * 1e-4 * (1.0 - 1.0 / 32.0);
    uint32_t q = (uint32_t)lrint(0.75 / step), e = 0;
    while ((q >> (e + 1)) != 0) e++;
    const size_t bits = rl_bits_offset(buf.data);
    assert_int_equal(buf.data[bits] & 31u, e - 5u);
    /* the sign bit (0) and the bits below the leading one follow */
    uint64_t w = 0;
    for (int b = 0; b < 8; b++) w |= (uint64_t)buf.data[bits + (size_t)b] << (8 * b);
    assert_int_equal((w >> 5) & 1u, 0);
    assert_int_equal((w >> 6) & ((1ull << e) - 1u), q - (1u << e));
    for (uint32_t bad = 25; bad < 32; bad += 6) {
        memcpy(c = malloc(buf.len), buf.data, buf.len);
        c[bits] = (uint8_t)((c[bits] & ~31u) | bad);
        restamp_crc(c, buf.len);
        expect_reject(&d2, c, buf.len, got, ns * nv * 3u, CORE_EFORMAT);
        assert_int_equal(codec_decode(&d2, c, buf.len, got, ns * nv * 3u, NULL, &err), CORE_EFORMAT);
        assert_non_null(strstr(err.msg, "escape"));
        free(c);
    }
    codec_buf_free(&buf);
    codec_encoder_free(&enc);
    codec_decoder_free(&d2);
    free(out);
    codec_decoder_free(&dec);
    free_frames(&f);
}

/* ---------------------------------------------------------------- hair mesh frames */

/* Hair mesh frames (codec id 2): a violent animation of 37 columns x 6 layers round-trips within
 * the bound, keyframes and deltas, and the header says what it is; the encoder refuses a stride
 * or an unknown codec; a decoder refuses a mesh frame of stride 2 and a mesh delta against a
 * strand keyframe of the same layout. */
static void test_hairmesh_frames(void **state)
{
    (void)state;
    const uint32_t ncols = 37, nlayers = 6;
    const size_t n = (size_t)ncols * nlayers * 3u;
    codec_encoder enc, senc;
    codec_decoder dec;
    core_err err;
    codec_desc bad = { .codec_id = CODEC_ID_HAIRMESH, .stride = 2 };
    assert_int_equal(codec_encoder_init(&enc, &bad, ncols, nlayers, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "stride 1"));
    bad = (codec_desc){ .codec_id = 3 };
    assert_int_equal(codec_encoder_init(&enc, &bad, ncols, nlayers, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "unknown codec id 3"));
    codec_desc d = { .max_error_m = 5e-5f, .key_interval = 4, .codec_id = CODEC_ID_HAIRMESH };
    codec_desc sd = { .max_error_m = 5e-5f, .key_interval = 4 };
    assert_int_equal(codec_encoder_init(&enc, &d, ncols, nlayers, &err), CORE_OK);
    assert_int_equal(codec_encoder_init(&senc, &sd, ncols, nlayers, &err), CORE_OK);
    codec_decoder_init(&dec);
    float *in = malloc(n * sizeof *in), *out = malloc(n * sizeof *out);
    codec_buf buf = { 0 }, sbuf = { 0 };
    int keys = 0, deltas = 0;
    for (int f = 0; f < 12; f++) {
        double t = 0.05 * f;
        codec_synth_frame(ncols, nlayers, t, CODEC_SYNTH_VIOLENT, in);
        assert_int_equal(encode_at(&enc, in, 10u + (uint64_t)f, t, false, &buf, &err), CORE_OK);
        codec_frame_info info;
        assert_int_equal(codec_peek_header(buf.data, buf.len, &info, &err), CORE_OK);
        assert_int_equal(info.codec_id, CODEC_ID_HAIRMESH);
        assert_int_equal(buf.data[6], CODEC_ID_HAIRMESH);
        assert_int_equal(codec_decode(&dec, buf.data, buf.len, out, n, &info, &err), CORE_OK);
        assert_true(info.nstrands_sent == ncols && info.nverts == nlayers && info.stride == 1);
        assert_true(max_abs_err(in, out, n) <= 5e-5);
        if (info.keyframe) keys++;
        else deltas++;
        /* the same positions as strands: the strand keyframe does not serve the mesh's deltas */
        assert_int_equal(encode_at(&senc, in, 10u + (uint64_t)f, t, false, &sbuf, &err), CORE_OK);
        assert_int_equal(sbuf.data[6], CODEC_ID_STRAND);
    }
    assert_true(keys >= 2 && deltas >= 6);
    codec_synth_frame(ncols, nlayers, 0.6, CODEC_SYNTH_VIOLENT, in);
    assert_int_equal(encode_at(&senc, in, 30, 0.6, true, &sbuf, &err), CORE_OK);  /* strand key 30 */
    assert_int_equal(encode_at(&enc, in, 30, 0.6, true, &buf, &err), CORE_OK);    /* mesh key 30 */
    assert_int_equal(encode_at(&enc, in, 31, 0.65, false, &buf, &err), CORE_OK);  /* mesh delta of 30 */
    codec_decoder sdec;
    codec_decoder_init(&sdec);
    assert_int_equal(codec_decode(&sdec, sbuf.data, sbuf.len, out, n, NULL, &err), CORE_OK);
    expect_reject(&sdec, buf.data, buf.len, out, n, CORE_EFORMAT);
    assert_int_equal(codec_decode(&sdec, buf.data, buf.len, out, n, NULL, &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "keyframe's layout"));
    /* a mesh frame must carry every column */
    uint8_t *c = malloc(sbuf.len);
    memcpy(c, sbuf.data, sbuf.len);
    c[6] = CODEC_ID_HAIRMESH;
    put32(c + 56, 2);
    put32(c + 48, (ncols + 1u) / 2u);
    restamp_crc(c, sbuf.len);
    codec_frame_info info;
    assert_int_equal(codec_peek_header(c, sbuf.len, &info, &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "a hair mesh frame has stride 1, not 2"));
    free(c);
    free(in);
    free(out);
    codec_buf_free(&buf);
    codec_buf_free(&sbuf);
    codec_decoder_free(&dec);
    codec_decoder_free(&sdec);
    codec_encoder_free(&enc);
    codec_encoder_free(&senc);
}

/* ---------------------------------------------------------------- test vectors */

typedef struct vstream {
    const char *name;
    uint32_t codec_id; /* CODEC_ID_HAIRMESH: the "strands" are a hair mesh's columns, nverts its layers */
    uint32_t nstrands, nverts, stride, key_interval;
    float bound;
    codec_synth_style style;
    int nframes;
    double t0, dt;
    int force_at; /* frame index encoded with force_key, or -1 */
} vstream;

static const vstream VSTREAMS[] = {
    { "basic", CODEC_ID_STRAND, 24, 12, 1, 3, 1e-4f, CODEC_SYNTH_GENTLE, 5, 0.0, 1.0 / 30.0, -1 },
    { "stride3", CODEC_ID_STRAND, 24, 12, 3, 30, 5e-4f, CODEC_SYNTH_VIOLENT, 4, 0.25, 1.0 / 60.0, 2 },
    { "teleport", CODEC_ID_STRAND, 16, 9, 1, 30, 2e-5f, CODEC_SYNTH_TELEPORT, 3, 0.95, 0.05, -1 },
    { "partial", CODEC_ID_STRAND, 13, 10, 1, 4, 2e-4f, CODEC_SYNTH_VIOLENT, 6, 0.4, 1.0 / 30.0, -1 },
    { "hairmesh", CODEC_ID_HAIRMESH, 21, 5, 1, 3, 1e-4f, CODEC_SYNTH_VIOLENT, 5, 0.1, 1.0 / 30.0, -1 },
};

static char *vpath(const char *dir, const char *name, int frame, const char *ext)
{
    static char buf[4][1024];
    static int slot;
    slot = (slot + 1) % 4;
    if (frame >= 0) snprintf(buf[slot], sizeof buf[slot], "%s/%s_%d.%s", dir, name, frame, ext);
    else snprintf(buf[slot], sizeof buf[slot], "%s/%s", dir, name);
    return buf[slot];
}

static uint8_t *slurp(const char *path, size_t *len)
{
    FILE *fp = fopen(path, "rb");
    if (!fp) fail_msg("cannot open %s (run with STRANDCAST_WRITE_VECTORS=1 to create it)", path);
    fseek(fp, 0, SEEK_END);
    long sz = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    uint8_t *p = malloc(sz > 0 ? (size_t)sz : 1u);
    assert_non_null(p);
    assert_true(fread(p, 1, (size_t)sz, fp) == (size_t)sz);
    fclose(fp);
    *len = (size_t)sz;
    return p;
}

/* Checks a generated artifact against the stored one, or writes it. */
static void check_or_write(const char *path, const void *data, size_t len, bool write)
{
    if (write) {
        FILE *fp = fopen(path, "wb");
        assert_non_null(fp);
        assert_true(fwrite(data, 1, len, fp) == len);
        fclose(fp);
        return;
    }
    size_t have;
    uint8_t *stored = slurp(path, &have);
    if (have != len || memcmp(stored, data, len) != 0)
        fail_msg("%s differs from what the encoder produces now (format drift?)", path);
    free(stored);
}

static void test_vectors(void **state)
{
    (void)state;
    const char *src = getenv("STRANDCAST_SOURCE_DIR");
    const char *w = getenv("STRANDCAST_WRITE_VECTORS");
    bool write = w && strcmp(w, "1") == 0;
    char dir[900];
    snprintf(dir, sizeof dir, "%s/proto/vectors", src ? src : STRANDCAST_SOURCE_DIR);
    char manifest[16384];
    size_t mlen = (size_t)snprintf(manifest, sizeof manifest, "{\n  \"format_version\": %u,\n  \"streams\": [\n",
                                   CODEC_VERSION);
    for (size_t s = 0; s < sizeof VSTREAMS / sizeof VSTREAMS[0]; s++) {
        const vstream *v = &VSTREAMS[s];
        codec_desc d = { .max_error_m = v->bound, .key_interval = v->key_interval, .stride = v->stride,
                         .codec_id = v->codec_id };
        codec_encoder enc;
        codec_decoder dec;
        core_err err;
        codec_buf buf = { 0 };
        assert_int_equal(codec_encoder_init(&enc, &d, v->nstrands, v->nverts, &err), CORE_OK);
        codec_decoder_init(&dec);
        size_t n = (size_t)v->nstrands * v->nverts * 3u, nsent = (size_t)enc.nstrands_sent * v->nverts * 3u;
        float *in = malloc(n * sizeof *in), *want = malloc(nsent * sizeof *want), *out = malloc(nsent * sizeof *out);
        mlen += (size_t)snprintf(manifest + mlen, sizeof manifest - mlen,
                                 "    {\"name\": \"%s\", \"codec\": %u, \"nstrands\": %u, \"nverts\": %u, \"stride\": %u, "
                                 "\"nstrands_sent\": %u, \"max_error_m\": %.9g, \"key_interval\": %u, \"frames\": [\n",
                                 v->name, v->codec_id, v->nstrands, v->nverts, v->stride, enc.nstrands_sent, (double)v->bound,
                                 v->key_interval);
        for (int f = 0; f < v->nframes; f++) {
            double t = v->t0 + v->dt * f;
            if (write) {
                codec_synth_frame(v->nstrands, v->nverts, t, v->style, in);
                check_or_write(vpath(dir, v->name, f, "in.f32"), in, n * sizeof *in, true);
            } else {
                size_t len;
                uint8_t *p = slurp(vpath(dir, v->name, f, "in.f32"), &len);
                assert_int_equal(len, n * sizeof *in);
                memcpy(in, p, len);
                free(p);
            }
            uint64_t seq = 1000u + (uint64_t)f * 2u;
            const codec_sim_info snap = codec_synth_sim(t, seq / 2u, v->style); /* the animation's head */
            assert_int_equal(codec_encode(&enc, in, seq, &snap, f == v->force_at, &buf, &err), CORE_OK);
            codec_frame_info info;
            assert_int_equal(codec_decode(&dec, buf.data, buf.len, out, nsent, &info, &err), CORE_OK);
            gather(in, v->nstrands, v->nverts, v->stride, want);
            assert_true(max_abs_err(want, out, nsent) <= (double)v->bound);
            check_or_write(vpath(dir, v->name, f, "bin"), buf.data, buf.len, write);
            check_or_write(vpath(dir, v->name, f, "out.f32"), out, nsent * sizeof *out, write);
            mlen += (size_t)snprintf(manifest + mlen, sizeof manifest - mlen,
                                     "      {\"file\": \"%s_%d\", \"seq\": %llu, \"ref_seq\": %llu, "
                                     "\"sim_time\": %.17g, \"sim_step\": %llu, \"head_position\": [%.9g, %.9g, %.9g], "
                                     "\"head_orientation\": [%.9g, %.9g, %.9g, %.9g], \"keyframe\": %s, \"bytes\": %zu}%s\n",
                                     v->name, f, (unsigned long long)seq, (unsigned long long)info.ref_seq, t,
                                     (unsigned long long)snap.sim_step, (double)snap.head_pos[0], (double)snap.head_pos[1],
                                     (double)snap.head_pos[2], (double)snap.head_rot[0], (double)snap.head_rot[1],
                                     (double)snap.head_rot[2], (double)snap.head_rot[3], info.keyframe ? "true" : "false",
                                     buf.len, f + 1 < v->nframes ? "," : "");
            assert_int_equal(info.codec_id, v->codec_id);
            assert_true(info.sim.sim_step == snap.sim_step);
            assert_memory_equal(info.sim.head_pos, snap.head_pos, sizeof snap.head_pos);
            assert_memory_equal(info.sim.head_rot, snap.head_rot, sizeof snap.head_rot);
        }
        mlen += (size_t)snprintf(manifest + mlen, sizeof manifest - mlen, "    ]}%s\n",
                                 s + 1 < sizeof VSTREAMS / sizeof VSTREAMS[0] ? "," : "");
        free(in);
        free(want);
        free(out);
        codec_buf_free(&buf);
        codec_decoder_free(&dec);
        codec_encoder_free(&enc);
    }
    mlen += (size_t)snprintf(manifest + mlen, sizeof manifest - mlen, "  ]\n}\n");
    assert_true(mlen < sizeof manifest);
    check_or_write(vpath(dir, "manifest.json", -1, ""), manifest, mlen, write);
}

/* Decodes the stored vectors (not the regenerated ones): every frame in order, then only the
 * keyframes and the last frame of each stream, bit for bit against the stored positions. */
static void test_vectors_decode(void **state)
{
    (void)state;
    const char *src = getenv("STRANDCAST_SOURCE_DIR");
    char dir[900];
    snprintf(dir, sizeof dir, "%s/proto/vectors", src ? src : STRANDCAST_SOURCE_DIR);
    for (size_t s = 0; s < sizeof VSTREAMS / sizeof VSTREAMS[0]; s++) {
        const vstream *v = &VSTREAMS[s];
        for (int pass = 0; pass < 2; pass++) {
            codec_decoder dec;
            codec_decoder_init(&dec);
            int decoded = 0;
            for (int f = 0; f < v->nframes; f++) {
                size_t len, olen;
                uint8_t *bin = slurp(vpath(dir, v->name, f, "bin"), &len);
                uint8_t *want = slurp(vpath(dir, v->name, f, "out.f32"), &olen);
                codec_frame_info info;
                core_err err;
                assert_int_equal(codec_peek_header(bin, len, &info, &err), CORE_OK);
                if (pass == 0 || info.keyframe || f == v->nframes - 1) {
                    float *out = malloc(olen);
                    core_status st = codec_decode(&dec, bin, len, out, olen / sizeof(float), &info, &err);
                    if (st) fail_msg("%s_%d: %s", v->name, f, err.msg);
                    assert_int_equal(info.nverts, v->nverts);
                    assert_int_equal(info.stride, v->stride);
                    assert_int_equal(info.codec_id, v->codec_id);
                    assert_memory_equal(out, want, olen);
                    free(out);
                    decoded++;
                }
                free(bin);
                free(want);
            }
            assert_true(decoded >= 2);
            codec_decoder_free(&dec);
        }
    }
}

/* The modes vectors (proto/vectors/modes_*, made by the reference encoder tests/js/codec_encode.mjs
 * from proto/CODEC.md; tests/js/mode_vectors.mjs lists them): every prediction mode, delta mode 3
 * (which this encoder never writes) included, partial groups and escapes, decoded in stream order
 * bit for bit. */
static void test_mode_vectors(void **state)
{
    (void)state;
    static const uint32_t shapes[][2] = { { 1, 2 }, { 3, 3 }, { 8, 4 }, { 13, 9 }, { 17, 33 } };
    const char *src = getenv("STRANDCAST_SOURCE_DIR");
    char dir[900], name[64];
    snprintf(dir, sizeof dir, "%s/proto/vectors", src ? src : STRANDCAST_SOURCE_DIR);
    for (size_t s = 0; s < sizeof shapes / sizeof shapes[0]; s++) {
        codec_decoder dec;
        codec_decoder_init(&dec);
        snprintf(name, sizeof name, "modes_%ux%u", shapes[s][0], shapes[s][1]);
        for (int f = 0; f < 5; f++) {
            size_t len, olen;
            uint8_t *bin = slurp(vpath(dir, name, f, "bin"), &len);
            uint8_t *want = slurp(vpath(dir, name, f, "out.f32"), &olen);
            assert_int_equal(olen, (size_t)shapes[s][0] * shapes[s][1] * 3u * sizeof(float));
            float *out = malloc(olen);
            core_err err;
            if (codec_decode(&dec, bin, len, out, olen / sizeof(float), NULL, &err)) fail_msg("%s_%d: %s", name, f, err.msg);
            assert_memory_equal(out, want, olen);
            free(out);
            free(bin);
            free(want);
        }
        codec_decoder_free(&dec);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_vectors),
        cmocka_unit_test(test_vectors_decode),
        cmocka_unit_test(test_mode_vectors),
        cmocka_unit_test(test_bound_all_styles),
        cmocka_unit_test(test_bound_resets),
        cmocka_unit_test(test_bound_magnitudes),
        cmocka_unit_test(test_bound_long_segments),
        cmocka_unit_test(test_bound_float32_reach),
        cmocka_unit_test(test_encoder_rejects),
        cmocka_unit_test(test_reference_rules),
        cmocka_unit_test(test_truncated_prefixes),
        cmocka_unit_test(test_bit_flips),
        cmocka_unit_test(test_absurd_headers),
        cmocka_unit_test(test_bad_head),
        cmocka_unit_test(test_v2_rejections),
        cmocka_unit_test(test_hairmesh_frames),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
