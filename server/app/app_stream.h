/* app: the frame streams: one codec encoder and one net stream per distinct (stride,
 * max_error, decimation), shared by every client subscribed with those settings. Owns the
 * encoders and the encode buffer; borrows net. Sim thread only. */
#ifndef APP_STREAM_H
#define APP_STREAM_H

#include <stdbool.h>
#include <stdint.h>

#include "codec/codec.h"
#include "net/net.h"
#include "proto/proto.h"

struct app_nats;

#define APP_MAX_DECIMATION 100000u /* publish rounds per stream frame, at most */

typedef struct app_stream {
    bool used;
    proto_source source;      /* strands, or the hair mesh's vertices (stride 1) */
    int32_t stride;
    double max_error;
    uint32_t decimation;      /* the stream takes every decimation-th publish round */
    uint32_t countdown;       /* rounds until its next frame (0: the next round) */
    bool due;                 /* encode it in the current publish round */
    uint32_t subscribers;
    bool force_key;
    bool ready;               /* encoder initialised for the current groom */
    bool failing;             /* the last encode failed (logged and told once until one succeeds) */
    uint64_t fail_seq;        /* while failing: the first frame not sent, and why */
    core_err fail_err;
    codec_encoder enc;
} app_stream;

/* Every stream slot (index = net stream), the settings they are made with, and the groom
 * size their encoders are for. */
typedef struct app_streams {
    app_stream s[NET_MAX_STREAMS];
    net *net;                 /* borrowed; NULL: nothing is published (--no-net, tests) */
    struct app_nats *bus;     /* borrowed; NULL: frames go to WebSocket clients only (no --nats) */
    double rate;              /* the server's publish rate, Hz */
    double max_error;         /* the default stream's bound, m */
    uint32_t keyframe_interval;
    uint32_t nstrands, nverts;
    uint32_t ncols, nlayers;  /* the groom's hair mesh (0 x 0: none): what hair mesh streams carry */
    uint64_t frame_seq;
    codec_buf enc_buf;
} app_streams;

/* What one publish round did (for the stats). */
typedef struct app_publish_result {
    uint64_t frames, bytes;
    uint32_t began_failing;   /* bit i: stream i's frames stopped being encodable this round */
} app_publish_result;
_Static_assert(NET_MAX_STREAMS <= 32, "began_failing holds one bit per stream");

/* No stream yet; settings as above. The caller owns ss (app_streams_free). */
void app_streams_init(app_streams *ss, net *n, double rate, double max_error, uint32_t keyframe_interval,
                      uint32_t nstrands, uint32_t nverts);
void app_streams_free(app_streams *ss);
/* Strands per frame at a stride: ceil(nstrands / stride). Pure. */
uint32_t app_stream_strands(uint32_t nstrands, int32_t stride);
/* The decimation of a client capped at max_rate (Hz, 0 = no cap) when the server publishes at
 * rate Hz: the largest k (1..APP_MAX_DECIMATION) with rate / k >= max_rate. Pure. */
uint32_t app_stream_decimation(double rate, double max_rate);
/* Adds a subscriber to the stream of (source, stride, max_error, app_stream_decimation(rate,
 * max_rate)) (a hair mesh stream's stride is 1 whatever stride says),
 * creating it (its first frame, in the next publish round, is a keyframe). The last free slot
 * of NET_MAX_STREAMS is kept for the default stream (stride 1, the default max_error, every
 * round), so a new client always has one. When no slot can be had it shares the stream of the
 * same stride and max_error with the largest smaller decimation (a faster stream; the net rate
 * cap thins it). Returns the stream index, or -1 when no slot is free and no stream fits. */
int app_stream_acquire(app_streams *ss, proto_source source, int32_t stride, double max_error, double max_rate);
/* Drops a subscriber; the last one frees the encoder and the net stream. */
void app_stream_release(app_streams *ss, int stream);
/* Re-initialises every stream's encoder for a new groom size (after a groom change) and hair
 * mesh size (ncols x nlayers, 0 x 0 for none); no frame of the old groom is sent after this. */
void app_streams_regroom(app_streams *ss, uint32_t nstrands, uint32_t nverts, uint32_t ncols, uint32_t nlayers);
/* Sets the hair mesh size hair mesh streams are made for (ncols x nlayers; 0 x 0: none, and
 * hair mesh streams made then are not ready). */
void app_streams_set_hairmesh(app_streams *ss, uint32_t ncols, uint32_t nlayers);
/* True when a due stream carries the hair mesh (the mesh must then be read for the round). */
bool app_streams_mesh_due(const app_streams *ss);
/* Marks the streams with subscribers that take a frame now: on a tick (a publish round of the
 * --rate schedule) those whose decimation countdown runs out, which it advances; with all,
 * every one (a frame outside the schedule: paused newcomers, reset, keyframe requests while
 * paused). Returns true when any is due. */
bool app_streams_due(app_streams *ss, bool tick, bool all);
/* Asks stream's next frame to be a keyframe (no-op for a bad index). */
void app_stream_force_key(app_streams *ss, int stream);
/* Every stream's next frame is a keyframe. */
void app_streams_force_keys(app_streams *ss);
/* Encodes xyz (strand-major, the current groom) with the snapshot it belongs to (sim: time, step,
 * head transform; the frames' headers carry it) once per due strand stream, and mesh (the hair
 * mesh's vertices, column-major; NULL: the hair mesh streams skip this round) once per due hair
 * mesh stream, and publishes the frames (one seq per call, so a stream of decimation k sees seq
 * grow by k per frame). */
app_publish_result app_streams_publish(app_streams *ss, const float *xyz, const float *mesh, const codec_sim_info *sim);
/* When stream's frames are not being sent because they cannot be encoded: fills *e (code
 * failed, field "stream") and returns true; false while it encodes. */
bool app_stream_failure(const app_streams *ss, int stream, proto_error *e);

#endif
