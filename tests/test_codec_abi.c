/* Tests for server/codec/codec_abi: the stable C ABI over the decoder (what the Python client
 * loads through ctypes) on the stored test vectors (proto/vectors/basic_*): header accessors
 * (the simulation step and head transform included), bit-exact positions, and status codes and
 * messages for bad frames, a missing keyframe, a short output buffer and a NULL handle, leaving
 * the output, keyframe and header unchanged. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "codec/codec.h"
#include "codec/codec_abi.h"

#define NSTRANDS 24u /* the basic stream: proto/vectors/manifest.json */
#define NVERTS 12u
#define NFLOATS (NSTRANDS * NVERTS * 3u)

/* The contents of proto/vectors/NAME.EXT (caller frees); *len its size. */
static uint8_t *vector(const char *name, const char *ext, size_t *len)
{
    const char *src = getenv("STRANDCAST_SOURCE_DIR");
    char path[1024];
    snprintf(path, sizeof path, "%s/proto/vectors/%s.%s", src ? src : STRANDCAST_SOURCE_DIR, name, ext);
    FILE *fp = fopen(path, "rb");
    if (!fp) fail_msg("cannot open %s", path);
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

static void test_versions_and_names(void **state)
{
    (void)state;
    assert_int_equal(codec_abi_version(), CODEC_ABI_VERSION);
    assert_int_equal(codec_abi_format_version(), CODEC_VERSION);
    assert_string_equal(codec_abi_status_name(0), "ok");
    assert_string_equal(codec_abi_status_name(CORE_EINVAL), "invalid_argument");
    assert_string_equal(codec_abi_status_name(CORE_EFORMAT), "bad_format");
    assert_string_equal(codec_abi_status_name(CORE_ESTATE), "bad_state");
    assert_string_equal(codec_abi_status_name(-1), "unknown");
    assert_string_equal(codec_abi_status_name(99), "unknown");
}

/* The basic stream in order: keyframes 0 and 3, deltas 1, 2 (on 0) and 4 (on 3), seq 1000 + 2 f. */
static void test_decodes_vectors(void **state)
{
    (void)state;
    codec_abi_decoder *d = codec_abi_decoder_new();
    assert_non_null(d);
    assert_int_equal(codec_abi_seq(d), 0);
    assert_int_equal(codec_abi_nverts(d), 0);
    assert_string_equal(codec_abi_message(d), "");
    static const uint64_t refs[5] = { 1000, 1000, 1000, 1006, 1006 };
    float out[NFLOATS];
    for (int f = 0; f < 5; f++) {
        char name[32];
        snprintf(name, sizeof name, "basic_%d", f);
        size_t len, wlen;
        uint8_t *bin = vector(name, "bin", &len);
        uint8_t *want = vector(name, "out.f32", &wlen);
        assert_int_equal(wlen, sizeof out);
        assert_int_equal(codec_abi_peek(d, bin, len), 0);
        assert_int_equal(codec_abi_nstrands_sent(d) * codec_abi_nverts(d) * 3u, NFLOATS);
        memset(out, 0, sizeof out);
        const int st = codec_abi_decode(d, bin, len, out, NFLOATS);
        if (st) fail_msg("%s: %s", name, codec_abi_message(d));
        assert_memory_equal(out, want, sizeof out);
        assert_int_equal(codec_abi_seq(d), 1000u + 2u * (unsigned)f);
        assert_int_equal(codec_abi_ref_seq(d), refs[f]);
        assert_int_equal(codec_abi_keyframe(d), f == 0 || f == 3);
        assert_float_equal(codec_abi_sim_time(d), f / 30.0, 1e-12);
        assert_int_equal(codec_abi_sim_step(d), 500u + (unsigned)f);
        float pos[3], rot[4];
        codec_abi_head_position(d, pos);
        codec_abi_head_orientation(d, rot);
        if (f == 1) { /* manifest.json: head_position, head_orientation of basic_1 */
            assert_float_equal(pos[0], 0.0011665608f, 1e-9f);
            assert_float_equal(pos[1], 1.60109973f, 1e-7f);
            assert_float_equal(rot[0], 0.0032489188f, 1e-9f);
            assert_float_equal(rot[3], 0.999976754f, 1e-7f);
        }
        assert_float_equal(rot[0] * rot[0] + rot[1] * rot[1] + rot[2] * rot[2] + rot[3] * rot[3], 1.0f, 1e-4f);
        assert_float_equal(codec_abi_max_error_m(d), 1e-4, 1e-9);
        assert_true(codec_abi_step(d) > 0 && codec_abi_step(d) <= 2.0 * codec_abi_max_error_m(d));
        assert_int_equal(codec_abi_nstrands_total(d), NSTRANDS);
        assert_int_equal(codec_abi_nstrands_sent(d), NSTRANDS);
        assert_int_equal(codec_abi_nverts(d), NVERTS);
        assert_int_equal(codec_abi_stride(d), 1);
        assert_int_equal(codec_abi_codec_id(d), 1);
        assert_int_equal(codec_abi_frame_len(d), len);
        assert_int_equal(codec_abi_payload_len(d), len - CODEC_HEADER_SIZE);
        free(bin);
        free(want);
    }
    /* a hair mesh frame (manifest.json, stream "hairmesh": 21 columns of 5 layers) says so */
    size_t len;
    uint8_t *mesh = vector("hairmesh_0", "bin", &len);
    assert_int_equal(codec_abi_peek(d, mesh, len), 0);
    assert_int_equal(codec_abi_codec_id(d), 2);
    assert_int_equal(codec_abi_nstrands_sent(d), 21);
    assert_int_equal(codec_abi_nverts(d), 5);
    free(mesh);
    codec_abi_decoder_free(d);
}

/* Asserts out still holds the sentinel 7.0f everywhere. */
static void assert_untouched(const float *out)
{
    for (unsigned i = 0; i < NFLOATS; i++) assert_true(out[i] == 7.0f);
}

static void test_rejects_bad_frames(void **state)
{
    (void)state;
    codec_abi_decoder *d = codec_abi_decoder_new();
    assert_non_null(d);
    size_t len0, len1;
    uint8_t *key = vector("basic_0", "bin", &len0);
    uint8_t *delta = vector("basic_1", "bin", &len1);
    float out[NFLOATS];
    for (unsigned i = 0; i < NFLOATS; i++) out[i] = 7.0f;

    /* a delta before its keyframe */
    assert_int_equal(codec_abi_decode(d, delta, len1, out, NFLOATS), CORE_ESTATE);
    assert_non_null(strstr(codec_abi_message(d), "needs keyframe 1000"));
    assert_int_equal(codec_abi_seq(d), 0);
    assert_untouched(out);

    /* a flipped payload byte: the header reads (the CRC is not checked), the decode does not */
    key[len0 - 5] ^= 0x40u;
    assert_int_equal(codec_abi_peek(d, key, len0), 0);
    assert_int_equal(codec_abi_seq(d), 1000);
    assert_int_equal(codec_abi_decode(d, key, len0, out, NFLOATS), CORE_EFORMAT);
    assert_non_null(strstr(codec_abi_message(d), "CRC mismatch"));
    assert_untouched(out);
    key[len0 - 5] ^= 0x40u;

    /* truncated, garbage, an output too small: the header held stays the last good one's */
    assert_int_equal(codec_abi_peek(d, key, len0 - 1), CORE_EFORMAT);
    assert_non_null(strstr(codec_abi_message(d), "truncated"));
    assert_int_equal(codec_abi_peek(d, (const uint8_t *)"hello", 5), CORE_EFORMAT);
    assert_int_equal(codec_abi_decode(d, key, len0, out, NFLOATS - 1), CORE_EINVAL);
    assert_non_null(strstr(codec_abi_message(d), "output holds"));
    assert_int_equal(codec_abi_seq(d), 1000);
    assert_int_equal(codec_abi_nverts(d), NVERTS);
    assert_untouched(out);

    /* the keyframe still decodes after all that, and then its delta */
    assert_int_equal(codec_abi_decode(d, key, len0, out, NFLOATS), 0);
    assert_int_equal(codec_abi_decode(d, delta, len1, out, NFLOATS), 0);
    assert_int_equal(codec_abi_seq(d), 1002);
    free(key);
    free(delta);
    codec_abi_decoder_free(d);
}

static void test_null_handle(void **state)
{
    (void)state;
    float out[3];
    assert_int_equal(codec_abi_peek(NULL, (const uint8_t *)"x", 1), CORE_EINVAL);
    assert_int_equal(codec_abi_decode(NULL, (const uint8_t *)"x", 1, out, 3), CORE_EINVAL);
    assert_string_equal(codec_abi_message(NULL), "codec: NULL decoder");
    assert_int_equal(codec_abi_seq(NULL), 0);
    assert_int_equal(codec_abi_frame_len(NULL), 0);
    float rot[4] = { 1, 1, 1, 1 };
    codec_abi_head_orientation(NULL, rot);
    assert_true(rot[0] == 0 && rot[3] == 0);
    codec_abi_decoder_free(NULL);
    codec_abi_decoder *d = codec_abi_decoder_new();
    assert_int_equal(codec_abi_peek(d, NULL, 0), CORE_EINVAL);
    assert_int_equal(codec_abi_decode(d, NULL, 0, out, 3), CORE_EINVAL);
    codec_abi_decoder_free(d);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_versions_and_names),
        cmocka_unit_test(test_decodes_vectors),
        cmocka_unit_test(test_rejects_bad_frames),
        cmocka_unit_test(test_null_handle),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
