/* Tests for server/codec on frames recorded from the C reference solver: under violent head
 * motion, a reset and a head that jumps, every decoded coordinate stays within the bound at
 * 0.5, 0.1 and 0.02 mm (and at stride 3), for a decoder taking every frame and one skipping. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "codec/codec.h"
#include "sim/sim.h"
#include "support/sim_check.h"

#define NSTRANDS 509u /* not a multiple of 8: the last group of lanes is partial */
#define NVERTS 24u
#define NSTEPS 360    /* 6 s at 60 steps/s */
#define RESET_AT 150  /* sim_reset: every strand snaps back to its rest pose mid-keyframe-interval */
#define JUMP_AT 250   /* from here on the head is 0.4 m away: a rigid jump of every strand */
#define NSTREAMS 4

typedef struct stream {
    float bound;
    uint32_t stride;
    codec_encoder enc;
    codec_decoder every, some;
    float *want, *out, *out_some;
    size_t nsent;
    double worst;
    uint32_t keys, skipped_decodes;
} stream;

/* The head at step i: the shared violent script, 0.4 m off from JUMP_AT on. */
static core_xform head_at(int i)
{
    core_xform h = simcheck_head_motion(i / 60.0, 2.0);
    if (i >= JUMP_AT) h.pos = core_v3_add(h.pos, core_v3(0.4f, -0.1f, 0.25f));
    return h;
}

static void stream_open(stream *s, float bound, uint32_t stride)
{
    memset(s, 0, sizeof *s);
    s->bound = bound;
    s->stride = stride;
    codec_desc d = { .max_error_m = bound, .key_interval = 30, .stride = stride };
    core_err err;
    if (codec_encoder_init(&s->enc, &d, NSTRANDS, NVERTS, &err) != CORE_OK) fail_msg("encoder: %s", err.msg);
    codec_decoder_init(&s->every);
    codec_decoder_init(&s->some);
    s->nsent = (size_t)s->enc.nstrands_sent * NVERTS * 3u;
    s->want = malloc(s->nsent * sizeof *s->want);
    s->out = malloc(s->nsent * sizeof *s->out);
    s->out_some = malloc(s->nsent * sizeof *s->out_some);
    assert_true(s->want && s->out && s->out_some);
}

static void stream_close(stream *s)
{
    codec_encoder_free(&s->enc);
    codec_decoder_free(&s->every);
    codec_decoder_free(&s->some);
    free(s->want);
    free(s->out);
    free(s->out_some);
}

/* Encodes positions x of step i and decodes it: every frame into out (checked against the
 * bound), keyframes and every seventh frame into out_some (must equal out bit for bit). */
static void stream_frame(stream *s, const float *x, int i, codec_buf *buf)
{
    core_err err;
    const core_xform h = head_at(i);
    const codec_sim_info snap = { .sim_time = i / 60.0, .sim_step = (uint64_t)i + 1u,
                                  .head_pos = { h.pos.x, h.pos.y, h.pos.z },
                                  .head_rot = { h.rot.x, h.rot.y, h.rot.z, h.rot.w } };
    if (codec_encode(&s->enc, x, 100u + (uint64_t)i, &snap, false, buf, &err) != CORE_OK)
        fail_msg("step %d, %g m: encode: %s", i, (double)s->bound, err.msg);
    codec_frame_info info;
    if (codec_decode(&s->every, buf->data, buf->len, s->out, s->nsent, &info, &err) != CORE_OK)
        fail_msg("step %d, %g m: decode: %s", i, (double)s->bound, err.msg);
    size_t per = (size_t)NVERTS * 3u, o = 0;
    for (uint32_t k = 0; k < NSTRANDS; k += s->stride, o += per) memcpy(s->want + o, x + (size_t)k * per, per * sizeof *x);
    double worst = 0.0;
    for (size_t c = 0; c < s->nsent; c++) worst = simcheck_worse(worst, fabs((double)s->out[c] - (double)s->want[c]));
    if (!(worst <= (double)s->bound))
        fail_msg("step %d (%s): error %.9g m over the bound %g m", i, info.keyframe ? "keyframe" : "delta", worst,
                 (double)s->bound);
    s->worst = simcheck_worse(s->worst, worst);
    s->keys += info.keyframe;
    if (info.keyframe || i % 7 == 0) {
        if (codec_decode(&s->some, buf->data, buf->len, s->out_some, s->nsent, &info, &err) != CORE_OK)
            fail_msg("step %d, %g m: skipping decoder: %s", i, (double)s->bound, err.msg);
        if (memcmp(s->out, s->out_some, s->nsent * sizeof *s->out) != 0)
            fail_msg("step %d, %g m: a decoder that skipped frames decodes differently", i, (double)s->bound);
        s->skipped_decodes++;
    }
}

static void test_bound_on_simulation(void **state)
{
    (void)state;
    core_groom g;
    simcheck_groom(&g, GROOM_WAVY, NSTRANDS, NVERTS, 0);
    sim_params p;
    sim_params_default(&p);
    sim_desc d = { .backend = SIM_BACKEND_CPU };
    sim s;
    core_err err;
    if (sim_create(&s, &d, &g, &p, &err) != CORE_OK) fail_msg("sim_create: %s", err.msg);
    float *x = malloc(sizeof(float) * 3 * NSTRANDS * NVERTS), *prev = malloc(sizeof(float) * 3 * NSTRANDS * NVERTS);
    assert_true(x && prev);
    stream st[NSTREAMS];
    const float bounds[NSTREAMS] = { 5e-4f, 1e-4f, 2e-5f, 1e-4f };
    for (int k = 0; k < NSTREAMS; k++) stream_open(&st[k], bounds[k], k == 3 ? 3u : 1u);
    codec_buf buf = { 0 };
    double fastest = 0.0, reset_jump = 0.0;
    for (int i = 0; i < NSTEPS; i++) {
        if (i == RESET_AT) sim_reset(&s);
        sim_set_motion(&s, head_at(i));
        if (sim_step(&s, &err) != CORE_OK || sim_read_positions(&s, x, &err) != CORE_OK) fail_msg("step %d: %s", i, err.msg);
        if (i > 0) {
            double m = simcheck_mean_distance(x, prev, (size_t)NSTRANDS * NVERTS);
            if (i == RESET_AT) reset_jump = m;
            else if (i != JUMP_AT) fastest = simcheck_worse(fastest, m);
        }
        memcpy(prev, x, sizeof(float) * 3 * NSTRANDS * NVERTS);
        for (int k = 0; k < NSTREAMS; k++) stream_frame(&st[k], x, i, &buf);
    }
    /* the frames are what the test says: violent (cm per frame), a reset that moves the hair */
    if (!(fastest > 0.01)) fail_msg("the fastest frame moves the hair only %g m on average", fastest);
    if (!(reset_jump > 0.005)) fail_msg("the reset moved the hair only %g m on average", reset_jump);
    for (int k = 0; k < NSTREAMS; k++) {
        /* keyframes every 30 frames, none forced by the reset or the jump */
        assert_int_equal(st[k].keys, NSTEPS / 30);
        assert_true(st[k].skipped_decodes > st[k].keys);
        /* the bound is used, not trivially met */
        if (!(st[k].worst > 0.5 * (double)st[k].bound))
            fail_msg("%g m: the largest error is only %g m", (double)st[k].bound, st[k].worst);
        stream_close(&st[k]);
    }
    codec_buf_free(&buf);
    free(x);
    free(prev);
    sim_destroy(&s);
    core_groom_free(&g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bound_on_simulation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
