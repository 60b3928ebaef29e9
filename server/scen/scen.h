/* scen: scripted scenarios and frame invariants for strandcastc (`strandcastc run SCRIPT.json`,
 * `strandcastc check`): a script of timed steps (send, reply, frames, expect, check, ...) read
 * from JSON, what the client knows of the server (hello, params, state, head pose), the checks
 * on decoded frames, and the runner over a wsc connection. Client-side only: the daemon never
 * links it. Scripts are a file format of this tool, not protocol messages, so this module reads
 * JSON itself (cJSON) instead of going through proto/. Every call is made on the one thread that
 * owns the objects. The script format is documented in tests/scenarios/README.md. */
#ifndef SCEN_SCEN_H
#define SCEN_SCEN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "../codec/codec.h"
#include "../core/core.h"
#include "../core/groom_types.h"
#include "../core/math3.h"
#include "../proto/proto.h"

#define SCEN_MAX_COLLIDERS CORE_MAX_COLLIDERS /* as many as a groom may have */

/* ---- frame invariants (scen_check.c) ---- */

/* Bounds of the invariants. Zero means the default; a bound below zero turns its check off.
 * The codec's error bound (the frame's max_error_m) is always added on top: a vertex may be
 * off by it on each axis. */
typedef struct scen_check_desc {
    double max_stretch;    /* |segment - rest| / rest, default 0.02 */
    double max_depth;      /* metres inside an analytic collider, default 0.002 */
    double root_tolerance; /* metres between a root and the head-transformed rest root, default 0.001 */
    double min_fps;        /* frames per second over the whole check, default 0 (off) */
    double max_gap_ms;     /* longest wall time between two frames, default 1000 */
} scen_check_desc;

/* The worst case of one invariant over a check. */
typedef struct scen_check_worst {
    unsigned long frames_failed; /* frames with at least one violation */
    bool any;                    /* a value was measured (the fields below are set) */
    uint64_t seq;                /* frame of the worst value */
    uint32_t strand, vertex;     /* strand index in the groom (not in the frame), vertex in the strand */
    double value, limit;         /* measured value and the bound it was held to there */
    char what[96];               /* e.g. "inside capsule 1", "segment 7.91 mm, rest 7.70 mm" */
} scen_check_worst;

typedef enum scen_inv { SCEN_INV_FINITE, SCEN_INV_STRETCH, SCEN_INV_DEPTH, SCEN_INV_ROOT, SCEN_INV_COUNT } scen_inv;

/* A check in progress: counters and worst values. Plain data, owned by the caller. */
typedef struct scen_check {
    scen_check_desc d; /* with defaults filled in */
    unsigned long frames;
    unsigned long groom_unchecked; /* frames of a groom whose data this client does not hold
                                      (superseded before it was fetched) */
    unsigned long depth_unchecked; /* frames with collisions off */
    unsigned long long first_ns, last_ns, max_gap_ns;
    uint64_t max_gap_seq;
    scen_check_worst worst[SCEN_INV_COUNT];
} scen_check;

/* ---- what the client knows of the server (scen_world.c) ---- */

typedef enum scen_collider_kind { SCEN_SPHERE, SCEN_CAPSULE, SCEN_ELLIPSOID } scen_collider_kind;

/* An analytic collider of the hello, in the head frame. */
typedef struct scen_collider {
    scen_collider_kind kind;
    double c[3], b[3];  /* sphere/ellipsoid centre or capsule a; capsule b */
    double radius;      /* sphere, capsule */
    double radii[3];    /* ellipsoid semi-axes along the axes of rot */
    core_quat rot;      /* ellipsoid rotation */
} scen_collider;

#define SCEN_GROOM_MAX_BYTES ((uint64_t)PROTO_GROOM_HEADER + 16u * (1u << 24)) /* the largest groom data taken */

/* Fetches url (a path on the server the hello came from) into *body (malloc'd, *len bytes,
 * owned by the caller), taking at most max_bytes. CORE_OK, or a failure with the reason in err. */
typedef core_status (*scen_fetch_fn)(void *user, const char *url, size_t max_bytes, uint8_t **body, size_t *len,
                                     core_err *err);

/* The hello and every announcement since. Owns its JSON trees and arrays (scen_world_free). */
typedef struct scen_world {
    void *hello;  /* cJSON: the hello message */
    void *params; /* cJSON: every parameter's current value (hello.params.values + announcements) */
    void *state;  /* cJSON: the latest state (hello.state, then each state message) */
    void *groom;  /* cJSON: {groom, colliders, collider_mesh} of the hello, then of each groom message */
    uint32_t strands, verts;
    /* the groom data (GET groom.url), NULL while this client holds none: the server already
     * served a newer groom when it was fetched (its groom message is on its way) */
    float *rest_lengths; /* per strand */
    float *roots;        /* rest roots, head frame, 3 per strand */
    char data_etag[17];  /* the version held ("" none) */
    scen_fetch_fn fetch;
    void *fetch_user;
    scen_collider colliders[SCEN_MAX_COLLIDERS];
    int ncolliders;
} scen_world;

/* Reads the hello (text, len bytes) into w: the groom counts, the colliders, parameters and
 * state, and the groom data (rest lengths and roots), which it fetches with fetch (given
 * fetch_user; kept for the groom messages that follow). CORE_EFORMAT with the field named in
 * err when a part the checks need is missing or malformed, "groom data: ..." when the data
 * cannot be fetched or does not match groom.etag / groom.bytes / the counts. On failure w
 * holds nothing to free. */
core_status scen_world_hello(scen_world *w, const char *text, size_t len, scen_fetch_fn fetch, void *fetch_user,
                             core_err *err);
/* Takes one server text message: params/state announcements and replies update the values,
 * a groom message replaces the groom and colliders and fetches the groom data again when its
 * etag is new. A failure only for a groom message that cannot be read or whose data cannot be
 * fetched ("groom data: ..." in err); other malformed messages are ignored. */
core_status scen_world_text(scen_world *w, const char *text, core_err *err);
/* The head transform a frame was made under: the one its header carries. */
core_xform scen_world_head(const codec_frame_info *info);
/* Whether collisions are on (the "collisions" parameter; true when absent). */
bool scen_world_collisions_on(const scen_world *w);
/* The value at a dotted path ("values.gravity", "groom.etag") in what ("hello", "params",
 * "state", "groom"); NULL when absent. Owned by w, valid until the next scen_world_* call. */
const void *scen_world_value(const scen_world *w, const char *what, const char *path);
/* Frees what w holds and zeroes it (a zeroed w is fine). */
void scen_world_free(scen_world *w);

/* Starts a check with desc d (NULL: all defaults). */
void scen_check_begin(scen_check *c, const scen_check_desc *d);
/* Checks one decoded frame (xyz strand-major, info from codec_decode) received at arrival_ns
 * (monotonic): finite, segment lengths, collider depth and roots; the gap since the last frame.
 * w gives the groom and colliders, the frame's header the head transform. */
void scen_check_frame(scen_check *c, const scen_world *w, const codec_frame_info *info, const float *xyz,
                      unsigned long long arrival_ns);
/* Ends a check: true when every invariant held (frame rate and gaps included). Writes one line
 * per failed invariant to fp (when not NULL), each starting with prefix, naming the frame (seq),
 * strand, vertex and the measured value against its bound. */
bool scen_check_end(const scen_check *c, FILE *fp, const char *prefix);
/* Writes the check's figures as JSON members (no braces) into out (cap bytes). */
void scen_check_json(const scen_check *c, char *out, size_t cap);
/* The frame rate between the first and last frame into *fps; whether it holds min_fps (true
 * when that is off; false under it with fewer than two frames). */
bool scen_check_fps_ok(const scen_check *c, double *fps);

/* ---- scripts (scen_script.c) ---- */

typedef enum scen_kind {
    SCEN_SEND = 1,
    SCEN_REPLY,
    SCEN_FRAMES,
    SCEN_UNTIL_SIM_TIME,
    SCEN_UNTIL_STEP,
    SCEN_SLEEP,
    SCEN_EXPECT,
    SCEN_CHECK
} scen_kind;

/* One step of a script, as read from its JSON object. */
typedef struct scen_step {
    scen_kind kind;
    char *text;             /* send: the message text (owned) */
    double at_ms, at_sim_time, at_step; /* send: when (negative: not given) */
    int id_kind;            /* reply: 0 none (next reply without id), 1 number, 2 string */
    double id_num;
    char id_str[72];
    char reply_type[32];    /* reply: expected type ("" any but error) */
    char error[32];         /* reply: expected error code ("" none expected) */
    char field[96];         /* reply: expected error field (with error; "" not checked) */
    bool field_given;
    double count;           /* frames: how many; until_*: target; sleep: ms; check: frames */
    char what[16];          /* expect: hello, params, state, groom, frame or metrics */
    char path[128];         /* expect: dotted path */
    char *equals;           /* expect: the expected JSON value as text (owned; NULL: none) */
    double tolerance, min, max; /* expect: numbers (min/max NaN when not given) */
    double seconds;         /* check: wall seconds (0: by frames) */
    scen_check_desc check;  /* check: bounds */
    double timeout_ms;      /* how long the step may wait */
} scen_step;

/* A parsed script. Owns its steps. */
typedef struct scen_script {
    char name[128];
    scen_step *steps;
    size_t nsteps;
} scen_script;

/* Parses a script (JSON text, len bytes). CORE_EFORMAT with a message naming the step index and
 * the field ("step 3 (reply): field \"timeout_ms\": must be a finite number >= 0") for malformed
 * JSON, an unknown step kind or field, wrong types and non-finite numbers. On failure s holds
 * nothing to free. Pure. */
core_status scen_script_parse(scen_script *s, const char *text, size_t len, core_err *err);
/* Reads and parses a script file (at most 16 MiB); err does not repeat the path. */
core_status scen_script_load(scen_script *s, const char *path, core_err *err);
/* Frees the steps and zeroes s (a zeroed s is fine). */
void scen_script_free(scen_script *s);
/* The step kind's name as scripts spell it ("send", "reply", ...). Static. */
const char *scen_kind_name(scen_kind k);

/* ---- the runner (scen_run.c) ---- */

typedef struct scen_run_desc {
    const char *host; /* NULL: 127.0.0.1 */
    int port;         /* 0: 7681 */
    const char *room; /* the room to join (proto_room_valid; at /rooms/NAME); NULL: the default room at / */
    bool json;        /* one JSON object per step instead of a line */
    FILE *out;        /* NULL: stdout */
} scen_run_desc;

/* Connects to the daemon, reads its hello and runs the script's steps in order, printing one
 * line (or JSON object) per step. Returns 0 when every expectation held, 1 at the first failing
 * step (printed with what was seen) or when the connection fails. Blocks the calling thread. */
int scen_run(const scen_run_desc *d, const scen_script *s);

/* ---- command lines (scen_cli.c) ---- */

/* `strandcastc run [flags] SCRIPT.json` and `strandcastc check [flags]`: argv[0] is the
 * subcommand. Return the exit status: 0 held, 1 failed, 2 bad flags or script. */
int scen_cli_run(int argc, char **argv);
int scen_cli_check(int argc, char **argv);
/* `strandcastc --compare A.scfr B.scfr [--json]` (scen_compare.c): argv[0] is --compare. Returns
 * 0 when both files decode and have one shape, 1 when they cannot be compared, 2 for bad flags. */
int scen_cli_compare(int argc, char **argv);

#endif
