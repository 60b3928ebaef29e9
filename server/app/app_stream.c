/* app: the frame streams: one codec encoder per distinct (source, stride, max_error, decimation),
 * published to net. */
#include <math.h>
#include <string.h>

#include "app_nats.h"
#include "app_stream.h"

void app_streams_init(app_streams *ss, net *n, double rate, double max_error, uint32_t keyframe_interval,
                      uint32_t nstrands, uint32_t nverts)
{
    memset(ss, 0, sizeof *ss);
    ss->net = n;
    ss->rate = rate;
    ss->max_error = max_error;
    ss->keyframe_interval = keyframe_interval;
    ss->nstrands = nstrands;
    ss->nverts = nverts;
}

uint32_t app_stream_strands(uint32_t nstrands, int32_t stride)
{
    uint32_t k = stride > 0 ? (uint32_t)stride : 1u;
    return (nstrands + k - 1) / k;
}

static core_status stream_init(const app_streams *ss, app_stream *t, core_err *err)
{
    bool mesh = t->source == PROTO_SOURCE_HAIRMESH;
    codec_desc cd = { .max_error_m = (float)t->max_error, .key_interval = ss->keyframe_interval,
                      .stride = (uint32_t)t->stride, .codec_id = mesh ? CODEC_ID_HAIRMESH : CODEC_ID_STRAND };
    core_status st = mesh && !ss->ncols ? core_fail(err, CORE_ESTATE, "the groom has no hair mesh")
                     : codec_encoder_init(&t->enc, &cd, mesh ? ss->ncols : ss->nstrands, mesh ? ss->nlayers : ss->nverts, err);
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
static bool default_settings(const app_streams *ss, proto_source source, int32_t stride, double max_error,
                             uint32_t decimation)
{
    return source == PROTO_SOURCE_STRANDS && stride == 1 && max_error == ss->max_error && decimation == 1;
}

int app_stream_acquire(app_streams *ss, proto_source source, int32_t stride, double max_error, double max_rate)
{
    uint32_t decimation = app_stream_decimation(ss->rate, max_rate);
    if (source == PROTO_SOURCE_HAIRMESH) stride = 1;
    int free_slot = -1, nfree = 0, faster = -1;
    bool have_default = false;
    for (int i = 0; i < NET_MAX_STREAMS; i++) {
        app_stream *t = &ss->s[i];
        if (!t->used) {
            if (free_slot < 0) free_slot = i;
            nfree++;
            continue;
        }
        have_default = have_default || default_settings(ss, t->source, t->stride, t->max_error, t->decimation);
        if (t->source != source || t->stride != stride || t->max_error != max_error || t->decimation > decimation) continue;
        if (t->decimation == decimation) {
            t->subscribers++;
            return i;
        }
        if (faster < 0 || t->decimation > ss->s[faster].decimation) faster = i;
    }
    /* the last free slot is kept for the default stream, which every new client starts on */
    if (free_slot >= 0 && nfree == 1 && !have_default && !default_settings(ss, source, stride, max_error, decimation))
        free_slot = -1;
    if (free_slot < 0) {
        if (faster >= 0) ss->s[faster].subscribers++;
        return faster;
    }
    app_stream *t = &ss->s[free_slot];
    memset(t, 0, sizeof *t);
    t->used = true;
    t->source = source;
    t->stride = stride;
    t->max_error = max_error;
    t->decimation = decimation;
    t->subscribers = 1;
    core_err err;
    if (stream_init(ss, t, &err) != CORE_OK) core_log(CORE_LOG_ERROR, "app", "stream encoder: %s", err.msg);
    return free_slot;
}

void app_stream_release(app_streams *ss, int stream)
{
    if (stream < 0 || stream >= NET_MAX_STREAMS || !ss->s[stream].used) return;
    app_stream *t = &ss->s[stream];
    if (--t->subscribers > 0) return;
    codec_encoder_free(&t->enc);
    memset(t, 0, sizeof *t);
    if (ss->net) net_drop_stream(ss->net, (uint32_t)stream);
    if (ss->bus) app_nats_drop(ss->bus, (uint32_t)stream);
}

void app_streams_set_hairmesh(app_streams *ss, uint32_t ncols, uint32_t nlayers)
{
    ss->ncols = ncols;
    ss->nlayers = ncols ? nlayers : 0;
}

bool app_streams_mesh_due(const app_streams *ss)
{
    for (int i = 0; i < NET_MAX_STREAMS; i++)
        if (ss->s[i].due && ss->s[i].ready && ss->s[i].source == PROTO_SOURCE_HAIRMESH) return true;
    return false;
}

void app_streams_regroom(app_streams *ss, uint32_t nstrands, uint32_t nverts, uint32_t ncols, uint32_t nlayers)
{
    ss->nstrands = nstrands;
    ss->nverts = nverts;
    app_streams_set_hairmesh(ss, ncols, nlayers);
    for (int i = 0; i < NET_MAX_STREAMS; i++) {
        app_stream *t = &ss->s[i];
        if (!t->used) continue;
        /* no frame of the old groom may follow the groom message (posted after this); a failure
         * of the new groom's frames is told afresh */
        if (ss->net) net_drop_stream(ss->net, (uint32_t)i);
        if (ss->bus) app_nats_drop(ss->bus, (uint32_t)i);
        t->failing = false;
        codec_encoder_free(&t->enc);
        core_err err;
        if (stream_init(ss, t, &err) != CORE_OK) core_log(CORE_LOG_ERROR, "app", "stream encoder: %s", err.msg);
    }
}

void app_streams_free(app_streams *ss)
{
    for (int i = 0; i < NET_MAX_STREAMS; i++) codec_encoder_free(&ss->s[i].enc);
    memset(ss->s, 0, sizeof ss->s);
    codec_buf_free(&ss->enc_buf);
}

bool app_streams_due(app_streams *ss, bool tick, bool all)
{
    bool any = false;
    for (int i = 0; i < NET_MAX_STREAMS; i++) {
        app_stream *t = &ss->s[i];
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

void app_stream_force_key(app_streams *ss, int stream)
{
    if (stream >= 0 && stream < NET_MAX_STREAMS) ss->s[stream].force_key = true;
}

void app_streams_force_keys(app_streams *ss)
{
    for (int i = 0; i < NET_MAX_STREAMS; i++) ss->s[i].force_key = true;
}

bool app_stream_failure(const app_streams *ss, int stream, proto_error *e)
{
    if (stream < 0 || stream >= NET_MAX_STREAMS || !ss->s[stream].failing) return false;
    const app_stream *t = &ss->s[stream];
    proto_fail(e, PROTO_ERR_FAILED, "stream",
               "the frames of this stream (%s, stride %d, max_error %g m) cannot be encoded from seq %llu on: %s; "
               "none are sent until they can be (or subscribe with a larger max_error)",
               proto_source_name(t->source), t->stride, t->max_error, (unsigned long long)t->fail_seq, t->fail_err.msg);
    return true;
}

app_publish_result app_streams_publish(app_streams *ss, const float *xyz, const float *mesh, const codec_sim_info *sim)
{
    app_publish_result r = { 0, 0, 0 };
    if (!ss->net) return r;
    uint64_t seq = ++ss->frame_seq;
    for (int i = 0; i < NET_MAX_STREAMS; i++) {
        app_stream *t = &ss->s[i];
        const float *src = t->source == PROTO_SOURCE_HAIRMESH ? mesh : xyz;
        if (!t->due || !t->ready || !src) continue;
        core_err err;
        if (codec_encode(&t->enc, src, seq, sim, t->force_key, &ss->enc_buf, &err) != CORE_OK) {
            if (!t->failing) {
                core_log(CORE_LOG_WARN, "app", "stream %d: frames not sent from %llu on: %s", i, (unsigned long long)seq, err.msg);
                t->failing = true;
                t->fail_seq = seq;
                t->fail_err = err;
                r.began_failing |= 1u << i;
            }
            t->force_key = true;
            continue;
        }
        if (t->failing) core_log(CORE_LOG_INFO, "app", "stream %d: frames flow again", i);
        t->failing = false;
        t->force_key = false;
        codec_frame_info info;
        if (codec_peek_header(ss->enc_buf.data, ss->enc_buf.len, &info, &err) != CORE_OK) continue;
        net_buf *b = net_buf_new(ss->enc_buf.len);
        if (!b) continue;
        memcpy(net_buf_data(b), ss->enc_buf.data, ss->enc_buf.len);
        if (ss->bus) app_nats_frame(ss->bus, (uint32_t)i, b, seq, info.keyframe); /* before net takes b over */
        net_publish(ss->net, (uint32_t)i, b, seq, info.keyframe);
        r.frames++;
        r.bytes += ss->enc_buf.len;
    }
    return r;
}
