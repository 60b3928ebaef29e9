/* app: subscription tiers: one codec encoder per distinct (stride, max_error, decimation),
 * published to net. */
#include <math.h>
#include <string.h>

#include "app_internal.h"

uint32_t app_tier_strands(const app *a, int32_t stride)
{
    uint32_t k = stride > 0 ? (uint32_t)stride : 1u;
    return (a->groom.g.nstrands + k - 1) / k;
}

static core_status tier_init(app *a, app_tier *t, core_err *err)
{
    codec_desc cd = { (float)t->max_error, (uint32_t)a->d.keyframe_interval, (uint32_t)t->stride };
    core_status st = codec_encoder_init(&t->enc, &cd, a->groom.g.nstrands, a->groom.g.nverts, err);
    t->ready = st == CORE_OK;
    t->force_key = true;
    return st;
}

uint32_t app_stream_decimation(double rate, double max_rate)
{
    if (!(max_rate > 0.0) || !(rate > max_rate)) return 1;
    /* the relative slack keeps exact ratios (60 / 20) from rounding down to the next k */
    double k = floor(rate / max_rate * (1.0 + 1e-9));
    return k >= (double)APP_MAX_DECIMATION ? APP_MAX_DECIMATION : (uint32_t)k;
}

/* The settings every new client starts on: every strand, the server's bound, every round. */
static bool default_settings(const app *a, int32_t stride, double max_error, uint32_t decimation)
{
    return stride == 1 && max_error == a->d.max_error && decimation == 1;
}

int app_tier_acquire(app *a, int32_t stride, double max_error, double max_rate)
{
    uint32_t decimation = app_stream_decimation(a->d.rate, max_rate);
    int free_slot = -1, nfree = 0, faster = -1;
    bool have_default = false;
    for (int i = 0; i < NET_MAX_STREAMS; i++) {
        app_tier *t = &a->tiers[i];
        if (!t->used) {
            if (free_slot < 0) free_slot = i;
            nfree++;
            continue;
        }
        have_default = have_default || default_settings(a, t->stride, t->max_error, t->decimation);
        if (t->stride != stride || t->max_error != max_error || t->decimation > decimation) continue;
        if (t->decimation == decimation) {
            t->subscribers++;
            return i;
        }
        if (faster < 0 || t->decimation > a->tiers[faster].decimation) faster = i;
    }
    /* the last free slot is kept for the default stream, which every new client starts on */
    if (free_slot >= 0 && nfree == 1 && !have_default && !default_settings(a, stride, max_error, decimation))
        free_slot = -1;
    if (free_slot < 0) {
        if (faster >= 0) a->tiers[faster].subscribers++;
        return faster;
    }
    app_tier *t = &a->tiers[free_slot];
    memset(t, 0, sizeof *t);
    t->used = true;
    t->stride = stride;
    t->max_error = max_error;
    t->decimation = decimation;
    t->subscribers = 1;
    core_err err;
    if (tier_init(a, t, &err) != CORE_OK) core_log(CORE_LOG_ERROR, "app", "stream encoder: %s", err.msg);
    return free_slot;
}

void app_tier_release(app *a, int tier)
{
    if (tier < 0 || tier >= NET_MAX_STREAMS || !a->tiers[tier].used) return;
    app_tier *t = &a->tiers[tier];
    if (--t->subscribers > 0) return;
    codec_encoder_free(&t->enc);
    memset(t, 0, sizeof *t);
    if (a->net) net_drop_stream(a->net, (uint32_t)tier);
}

void app_tiers_reset(app *a)
{
    for (int i = 0; i < NET_MAX_STREAMS; i++) {
        app_tier *t = &a->tiers[i];
        if (!t->used) continue;
        /* no frame of the old groom may follow the groom message (posted after this); a failure
         * of the new groom's frames is told afresh */
        if (a->net) net_drop_stream(a->net, (uint32_t)i);
        t->failing = false;
        codec_encoder_free(&t->enc);
        core_err err;
        if (tier_init(a, t, &err) != CORE_OK) core_log(CORE_LOG_ERROR, "app", "stream encoder: %s", err.msg);
    }
}

void app_tiers_free(app *a)
{
    for (int i = 0; i < NET_MAX_STREAMS; i++) codec_encoder_free(&a->tiers[i].enc);
    memset(a->tiers, 0, sizeof a->tiers);
    codec_buf_free(&a->enc_buf);
}

bool app_tiers_due(app *a, bool tick, bool all)
{
    bool any = false;
    for (int i = 0; i < NET_MAX_STREAMS; i++) {
        app_tier *t = &a->tiers[i];
        t->due = false;
        if (!t->used || t->subscribers == 0) continue;
        if (tick) {
            if (t->countdown == 0) {
                t->due = true;
                t->countdown = t->decimation - 1;
            } else {
                t->countdown--;
            }
        }
        t->due = t->due || all;
        any = any || t->due;
    }
    return any;
}

void app_tier_tell_failure(app *a, int tier, uint32_t client)
{
    if (tier < 0 || tier >= NET_MAX_STREAMS || !a->tiers[tier].failing) return;
    const app_tier *t = &a->tiers[tier];
    proto_error e;
    proto_fail(&e, PROTO_ERR_FAILED, "stream",
               "the frames of this stream (stride %d, max_error %g m) cannot be encoded from seq %llu on: %s; "
               "none are sent until they can be (or subscribe with a larger max_error)",
               t->stride, t->max_error, (unsigned long long)t->fail_seq, t->fail_err.msg);
    for (size_t k = 0; k < a->nclients; k++)
        if (a->clients[k].tier == tier && (client == NET_ALL || a->clients[k].id == client))
            app_send(a, a->clients[k].id, proto_build_error(NULL, &e), 0);
}

void app_publish(app *a)
{
    if (!a->net) return;
    unsigned long long t0 = core_now_ns();
    uint64_t seq = ++a->frame_seq;
    uint64_t frames = 0, bytes = 0;
    sim_stats ss;
    sim_get_stats(&a->sim, &ss);
    for (int i = 0; i < NET_MAX_STREAMS; i++) {
        app_tier *t = &a->tiers[i];
        if (!t->due || !t->ready) continue;
        core_err err;
        if (codec_encode(&t->enc, a->xyz, seq, ss.sim_time, t->force_key, &a->enc_buf, &err) != CORE_OK) {
            if (!t->failing) {
                core_log(CORE_LOG_WARN, "app", "stream %d: frames not sent from %llu on: %s", i, (unsigned long long)seq, err.msg);
                t->failing = true;
                t->fail_seq = seq;
                t->fail_err = err;
                app_tier_tell_failure(a, i, NET_ALL);
            }
            t->force_key = true;
            continue;
        }
        if (t->failing) core_log(CORE_LOG_INFO, "app", "stream %d: frames flow again", i);
        t->failing = false;
        t->force_key = false;
        codec_frame_info info;
        if (codec_peek_header(a->enc_buf.data, a->enc_buf.len, &info, &err) != CORE_OK) continue;
        net_buf *b = net_buf_new(a->enc_buf.len);
        if (!b) continue;
        memcpy(net_buf_data(b), a->enc_buf.data, a->enc_buf.len);
        net_publish(a->net, (uint32_t)i, b, seq, info.keyframe);
        frames++;
        bytes += a->enc_buf.len;
    }
    double ms = (double)(core_now_ns() - t0) / 1e6;
    pthread_mutex_lock(&a->stats_mu);
    a->stats.frames_encoded += frames;
    a->stats.encode_bytes += bytes;
    pthread_mutex_unlock(&a->stats_mu);
    a->encode_ms_acc += ms;
    a->encode_rounds++;
}
