/* app: internal state of the pipeline shared by the app_*.c files (mailbox, streams, clients). */
#ifndef APP_INTERNAL_H
#define APP_INTERNAL_H

#include <pthread.h>
#include <stdatomic.h>

#include "app.h"
#include "app_anim.h"
#include "codec/codec.h"
#include "core/groom_types.h"
#include "core/math3.h"
#include "net/net.h"
#include "proto/proto.h"

#define APP_MAILBOX 256   /* queued commands from the net thread; more -> "busy" error */
#define APP_MAX_FILES 256 /* groom files listed from the asset folder */

/* ---- mailbox: net thread -> sim thread ---- */
typedef enum app_cmd_kind { APP_CMD_OPEN, APP_CMD_CLOSE, APP_CMD_MSG } app_cmd_kind;

typedef struct app_cmd {
    app_cmd_kind kind;
    uint32_t client;
    proto_msg msg;
} app_cmd;

typedef struct app_mailbox {
    pthread_mutex_t mu;
    pthread_cond_t cv;        /* signalled on every post (CLOCK_MONOTONIC waits) */
    app_cmd *ring;
    int head, len;
    bool wake;                /* set by app_mailbox_wake */
} app_mailbox;

core_status app_mailbox_init(app_mailbox *m, core_err *err);
void app_mailbox_free(app_mailbox *m);
/* Queues a copy of *c; a motion replaces a motion without an id still at the tail (newest wins;
 * one with an id is kept, for its reply).
 * CORE_ENOMEM when full. Any thread. */
core_status app_mailbox_post(app_mailbox *m, const app_cmd *c);
/* Takes the oldest command into *out; false when empty. Sim thread. */
bool app_mailbox_take(app_mailbox *m, app_cmd *out);
/* Blocks until a post, app_mailbox_wake, or the monotonic deadline (ns). Sim thread. */
void app_mailbox_wait(app_mailbox *m, unsigned long long deadline_ns);
/* Wakes app_mailbox_wait. Any thread. */
void app_mailbox_wake(app_mailbox *m);

/* ---- preset animations (the presets themselves: app_anim.h) ---- */
/* Seconds (of simulated time, whatever the speed) over which a change of preset blends from
 * the head pose at the change to the new motion. */
#define APP_ANIM_BLEND_S 0.4

/* The head animation (sim thread): the client's base pose, the running preset and the blend
 * from the pose the head had at the last change of preset. */
typedef struct app_anim {
    core_xform base;          /* last client motion */
    app_preset preset;
    double speed, time;       /* time: the preset's clock, s (advances by dt * speed) */
    core_xform from;          /* head pose at the last change of preset */
    double since;             /* simulated seconds since that change; >= APP_ANIM_BLEND_S: done */
} app_anim;

/* from moved toward to by weight w in [0, 1] (clamped): position lerp, rotation nlerp along the
 * shorter arc; w = 0 gives from, w = 1 gives to. Pure. */
core_xform app_anim_blend(core_xform from, core_xform to, double w);
/* The blend weight after `since` seconds of a change: smoothstep of since / APP_ANIM_BLEND_S
 * (0 at the change, 1 from APP_ANIM_BLEND_S on, zero slope at both ends). Pure. */
double app_anim_blend_weight(double since);
/* No preset, speed 1, identity base, no blend running. */
void app_anim_init(app_anim *s);
/* The head pose now: the preset on the base, blended from s->from while a blend runs. Pure. */
core_xform app_anim_pose(const app_anim *s);
/* Starts preset p (APP_PRESET_NONE stops) at speed from preset time 0, blending from the
 * current pose. Every call is a change, even to the running preset. Sim thread. */
void app_anim_start(app_anim *s, app_preset p, double speed);
/* A client motion: the new base. A running preset stops (blending from the current pose to
 * the new base); returns true when it did. Without a preset the head follows the base at once
 * (or the running blend heads for the new base). Sim thread. */
bool app_anim_motion(app_anim *s, core_xform base);
/* Advances the preset clock by dt * speed and the blend by dt (s). Sim thread. */
void app_anim_advance(app_anim *s, double dt);

/* ---- streams: one codec encoder per distinct (stride, max_error, decimation), each a net
 * stream ---- */
#define APP_MAX_DECIMATION 100000u /* publish rounds per stream frame, at most */

typedef struct app_tier {
    bool used;
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
} app_tier;

/* ---- clients as the sim thread sees them ---- */
typedef struct app_client {
    uint32_t id;
    int tier;
    int32_t stride;
    double max_error, max_rate;
    bool has_t;
    double last_t;            /* newest motion timestamp from this client */
} app_client;

#define APP_MESH_PATH "/collider.bin" /* where clients GET the collision mesh binary */

/* The live groom, its collision mesh binary and its pre-rendered JSON. */
typedef struct app_groom {
    core_groom g;             /* g.mesh / g.sdf: the collision mesh and its distance grid, if any */
    char source[PROTO_MAX_NAME + 16];
    uint64_t seed;
    char collider[PROTO_MAX_NAME + 1]; /* the mesh's name ("" = none) */
    net_buf *mesh_bin;        /* proto_mesh_bin_write of g.mesh (NULL = none) */
    char mesh_etag[17];
    double mesh_ms, sdf_ms;   /* time to load the mesh and build its grid */
    proto_groom_json json;
} app_groom;

/* One set_groom's loads (groom, collision mesh, SDF) on a loader thread: the sim thread
 * fills the job and starts it, the loader fills the result and sets done, the sim thread
 * collects it at a step boundary (app_regroom_poll). One at a time (grooms_pending). */
typedef struct app_loader {
    pthread_t thread;
    bool running;             /* sim thread: started and not yet collected */
    atomic_bool done;         /* loader: the result is ready */
    struct app *a;
    uint32_t client;
    proto_msg msg;
    /* the job (resolved on the sim thread) */
    char groom_path[2048];    /* a groom file, or "" for the procedural style */
    const char *label;        /* the groom file's name (a->files, immutable) */
    const char *style;
    uint32_t strands, verts;
    uint64_t seed;
    char mesh_path[2048];     /* a collision mesh file, or "" */
    bool has_keep;            /* keep: a copy of the live groom's mesh */
    core_mesh keep;
    char mesh_label[PROTO_MAX_NAME + 1];
    /* the result */
    app_groom g;
    core_status st;
    proto_code code;
    const char *field;
    core_err err;
    double groom_ms, total_ms;
} app_loader;

/* Numbers the sim thread publishes for /metrics and stats (guarded by stats_mu). */
typedef struct app_stats {
    uint64_t steps_run;       /* steps since the daemon started (never reset) */
    uint64_t nan_resets_run;  /* NaN restores since the daemon started (never reset) */
    uint64_t steps;           /* the sim's own count: since start, reset or groom change */
    double sim_time;
    double steps_per_s;       /* over the last stats window */
    double step_ms;           /* mean over the last stats window */
    double encode_ms;         /* mean per published round over the last window */
    uint64_t frames_encoded, encode_bytes, nan_resets; /* nan_resets: of the current sim, since reset */
    uint32_t clients;
} app_stats;

typedef struct app {
    app_desc d;

    /* modules */
    sim sim;
    net *net;
    app_groom groom;
    sim_params params;
    float *xyz;               /* positions of the current groom, strand-major */

    /* command plumbing */
    app_mailbox mb;
    proto_parser parser;
    const core_param_info *ptable;
    size_t nparams;
    const char *styles[3];
    char *files[APP_MAX_FILES];
    size_t nfiles;
    char *meshes[APP_MAX_FILES];  /* .obj/.tfxmesh files set_groom's collider may name */
    size_t nmeshes;

    /* sim thread state */
    bool paused;
    int32_t step_budget;      /* steps left while paused */
    bool dirty;               /* publish the current positions even when not stepping */
    app_anim anim;            /* head motion: client base pose, preset, blend */
    app_tier tiers[NET_MAX_STREAMS];
    app_client *clients;
    size_t nclients, cap_clients;
    uint64_t frame_seq;
    codec_buf enc_buf;
    double publish_acc;
    core_status fatal;        /* a sim-thread failure that stops the daemon */
    core_err fatal_err;

    /* measuring windows (sim thread) */
    unsigned long long win_start_ns, log_start_ns;
    uint64_t win_steps, log_steps;
    double step_ms_acc, log_step_ms_acc, encode_ms_acc;
    uint64_t encode_rounds;

    /* thread control */
    atomic_bool quit;         /* ask the sim thread to stop */
    atomic_bool sim_done;     /* the sim thread has finished (steps reached or failure) */

    /* stats */
    pthread_mutex_t stats_mu;
    app_stats stats;
    atomic_uint_fast64_t accepted, rejected;
    atomic_uint grooms_pending;   /* set_groom commands queued or being carried out (at most 1) */
    app_loader loader;            /* the set_groom being loaded (sim thread, loader thread) */
} app;

/* Net-thread callbacks (net_callbacks.user = app). */
void app_on_open(void *user, uint32_t client);
void app_on_text(void *user, uint32_t client, const char *text, size_t len);
void app_on_close(void *user, uint32_t client);
size_t app_metrics(void *user, char *buf, size_t cap);

/* Sends an error reply to one client (any thread) and counts the rejection. */
void app_reply_error(app *a, uint32_t client, const proto_id *id, const proto_error *e);
/* Sends text (freed here) to a client or NET_ALL; ignores NULL (out of memory) and --no-net. */
void app_send(app *a, uint32_t client, char *text, unsigned flags);

/* Groom handling (main thread at start-up, sim thread afterwards). Each fills *out (zeroed on
 * failure; the caller owns it and frees it with app_groom_free) with the groom and its JSON. */
/* A procedural groom: style name, counts (0 = 4096 strands, 32 vertices) and seed (0 = default). */
core_status app_groom_load_style(app *a, const char *style, uint32_t strands, uint32_t verts, uint64_t seed,
                                 app_groom *out, core_err *err);
/* A .tfx/.hair file at path, shown to clients as "file:<label>"; verts 0 = the file's count. */
core_status app_groom_load_path(app *a, const char *path, const char *label, uint32_t verts, app_groom *out,
                                core_err *err);
void app_groom_free(app_groom *g);
/* (Re-)renders g's JSON after a change of its mesh. */
core_status app_groom_render(app_groom *g, core_err *err);

/* Collision meshes (app_collider.c). */
/* Gives g the mesh (taking it over; *mesh is zeroed, also on failure), named label: its SDF
 * over groom_collider_region (2 mm cells, at most GROOM_COLLIDER_MAX_CELLS samples; none when
 * the hair cannot reach the mesh), its binary and the re-rendered JSON. mesh NULL removes
 * g's mesh. Any thread (g is the caller's). */
core_status app_groom_set_collider(app_groom *g, core_mesh *mesh, const char *label, core_err *err);
/* Hands the live groom's mesh binary to net (or none). */
void app_publish_mesh(app *a);
/* CORE_EINVAL (the counts in err) when g has more vertices than a groom may have
 * (PROTO_MAX_VERTICES: what set_groom and the hello's limits allow). Pure. */
core_status app_groom_check_size(const app_groom *g, core_err *err);
/* Lists the .tfx/.hair files under d.assets_dir into a->files and the .obj/.tfxmesh files
 * into a->meshes (sorted). */
void app_list_assets(app *a);
void app_free_assets(app *a);

/* Streams (sim thread). A tier is one codec encoder and one net stream, shared by every
 * client with the same (stride, max_error, decimation). */
/* The decimation of a client capped at max_rate (Hz, 0 = no cap) when the server publishes at
 * rate Hz: the largest k (1..APP_MAX_DECIMATION) with rate / k >= max_rate. Pure. */
uint32_t app_stream_decimation(double rate, double max_rate);
/* Adds a subscriber to the tier of (stride, max_error, app_stream_decimation(d.rate, max_rate)),
 * creating it (its first frame, in the next publish round, is a keyframe). The last free slot
 * of NET_MAX_STREAMS is kept for the default stream (stride 1, d.max_error, every round), so a
 * new client always has one. When no slot can be had it shares the tier of the same stride and
 * max_error with the largest smaller decimation (a faster stream; the net rate cap thins it).
 * Returns the tier index, or -1 when no slot is free and no tier fits. */
int app_tier_acquire(app *a, int32_t stride, double max_error, double max_rate);
/* Tells client (or every subscriber of the tier, with NET_ALL) that the tier's frames are not
 * being sent because they cannot be encoded: an error without id, code failed, field "stream".
 * Does nothing while the tier encodes. Sim thread. */
void app_tier_tell_failure(app *a, int tier, uint32_t client);
/* Drops a subscriber; the last one frees the encoder and the net stream. */
void app_tier_release(app *a, int tier);
/* Re-initialises every tier's encoder for the current groom (after a groom change). */
void app_tiers_reset(app *a);
void app_tiers_free(app *a);
/* Marks the tiers with subscribers that take a frame now: on a tick (a publish round of the
 * --rate schedule) those whose decimation countdown runs out, which it advances; with all,
 * every one (a frame outside the schedule: paused newcomers, reset, keyframe requests while
 * paused). Returns true when any is due. Sim thread. */
bool app_tiers_due(app *a, bool tick, bool all);

/* Encodes a->xyz once per due tier and publishes the frames (one seq per call, so a tier of
 * decimation k sees seq grow by k per frame). Sim thread. */
void app_publish(app *a);
/* Strands per frame at a stride: ceil(nstrands / stride). */
uint32_t app_tier_strands(const app *a, int32_t stride);

/* Commands (sim thread): carries out one command at a step boundary and sends its replies and
 * broadcasts. */
void app_handle(app *a, app_cmd *c);
/* The sim thread's body (pthread start routine; arg = app). */
void *app_sim_main(void *arg);
/* Replies (sim thread): an error with code, field and message; ok (counted as accepted). */
void app_reply_fail(app *a, uint32_t client, const proto_id *id, proto_code code, const char *field, const char *msg);
void app_reply_ok(app *a, uint32_t client, const proto_msg *m);
/* Puts the simulation back to its rest pose; its own counters restart at 0, so the baseline the
 * daemon's NaN total counts from does too (the daemon's totals go on). Sim thread. */
void app_reset_sim(app *a);
/* set_groom (app_regroom.c): checks the names (errors are replied at once) and starts the
 * loads on the loader thread; the swap, the replies and the groom broadcast follow in
 * app_regroom_poll. Drops grooms_pending when the request ends, before its replies. Sim thread. */
void app_set_groom(app *a, uint32_t client, const proto_msg *m);
/* Collects a finished load: swaps the groom in and replies, or replies the error. Sim thread,
 * at a step boundary. */
void app_regroom_poll(app *a);
/* Waits for a running load and drops its result (shutdown, after the sim thread ended). */
void app_regroom_join(app *a);
/* Current state/animation for state messages and hello. */
proto_state app_state(const app *a);

#endif
