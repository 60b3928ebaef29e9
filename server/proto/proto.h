/* proto: the strandcast.v3 control messages: JSON text <-> typed structs (the only cJSON user). */
#ifndef PROTO_PROTO_H
#define PROTO_PROTO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../core/core.h"
#include "../core/groom_types.h"
#include "../core/math3.h"
#include "../core/param.h"

#define PROTO_SUBPROTOCOL "strandcast.v3"
#define PROTO_VERSION 3
#define PROTO_MAX_MESSAGE (64 * 1024) /* largest client text message, bytes */
#define PROTO_MAX_PARAMS 64           /* largest parameter table proto can serve */
#define PROTO_MAX_ID 64               /* longest string request id, bytes */
#define PROTO_MAX_NAME 255            /* longest groom file name, bytes */
#define PROTO_MAX_STRANDS 65536
#define PROTO_MAX_VERTS 256
#define PROTO_MAX_VERTICES (2u * 1024u * 1024u) /* strands x verts of a requested groom */
#define PROTO_MAX_STEP 1000           /* largest "step" count */
#define PROTO_MAX_SPEED 20.0          /* largest animation speed factor */
#define PROTO_MAX_POSITION 5.0        /* largest |head position| component, m (the codec's float32 bound) */
#define PROTO_MAX_STRIDE 4096
#define PROTO_MIN_ERROR 1e-5          /* subscribe max_error range, m (the codec's lower bound) */
#define PROTO_MAX_ERROR 1e-2
#define PROTO_MAX_RATE 240.0          /* subscribe max_rate, Hz (0 = the server's rate) */
#define PROTO_MAX_TOKEN 256           /* auth token, bytes */
#define PROTO_MAX_ROOM 64             /* longest room name, bytes */
#define PROTO_DEFAULT_ROOM "default"  /* the room of the WebSocket path "/" */
#define PROTO_ROOM_PREFIX "/rooms/"   /* the page and WebSocket path of a room: /rooms/NAME */
#define PROTO_ROOM_PATH_MAX (sizeof PROTO_ROOM_PREFIX + PROTO_MAX_ROOM) /* its bytes with the NUL */
#define PROTO_CLOSE_BAD_ROOM 4400     /* close code: the path names no valid room */
#define PROTO_CLOSE_UNKNOWN_ROOM 4404 /* close code: a valid room this server does not serve */
#define PROTO_CLOSE_ROOM_UNAVAILABLE 4503 /* close code: the room's simulation node is gone (reconnect later) */

typedef enum proto_type {
    PROTO_GET_PARAMS = 1,
    PROTO_SET_PARAMS,
    PROTO_MOTION,
    PROTO_ANIMATE,
    PROTO_RESET,
    PROTO_PAUSE,
    PROTO_RESUME,
    PROTO_STEP,
    PROTO_SET_GROOM,
    PROTO_SUBSCRIBE,
    PROTO_KEYFRAME,
    PROTO_AUTH
} proto_type;

/* Stable error codes; proto_code_name gives the wire string. */
typedef enum proto_code {
    PROTO_ERR_NONE = 0,
    PROTO_ERR_BAD_JSON,      /* not JSON, or not a JSON object */
    PROTO_ERR_UNKNOWN_TYPE,  /* "type" names no client message */
    PROTO_ERR_BAD_FIELD,     /* missing, unknown, duplicated or wrongly typed field */
    PROTO_ERR_OUT_OF_RANGE,  /* number outside its documented range, or an unknown name */
    PROTO_ERR_NOT_FINITE,    /* number overflowed to infinity */
    PROTO_ERR_UNKNOWN_PARAM, /* set_params names a parameter not in the schema */
    PROTO_ERR_TOO_LARGE,     /* message, string or array over its limit */
    PROTO_ERR_NOT_FOUND,     /* groom file not in the asset list */
    PROTO_ERR_BAD_STATE,     /* request not valid now (e.g. step while running) */
    PROTO_ERR_BUSY,          /* the server's command queue is full; retry later */
    PROTO_ERR_RATE_LIMITED,  /* the client is over its control-message budget */
    PROTO_ERR_FORBIDDEN,     /* a read-only client asked to change shared state (or a wrong token) */
    PROTO_ERR_FAILED,        /* valid request that failed while being carried out */
    PROTO_ERR_BAD_ROOM,      /* the connection's path names no valid room (charset, length) */
    PROTO_ERR_UNKNOWN_ROOM,  /* a valid room name this server does not serve */
    PROTO_ERR_ROOM_UNAVAILABLE /* an edge relay lost (or never found) the simulation node of the room */
} proto_code;

/* A rejection: code, the offending field as a path ("values.gravity", "" for the whole
 * message) and a human-readable reason. */
typedef struct proto_error {
    proto_code code;
    char field[96];
    char message[224];
} proto_error;

typedef enum proto_id_kind { PROTO_ID_NONE = 0, PROTO_ID_NUMBER, PROTO_ID_STRING } proto_id_kind;

/* The optional request id, echoed verbatim in the reply. */
typedef struct proto_id {
    proto_id_kind kind;
    double num;
    char str[PROTO_MAX_ID + 1];
} proto_id;

typedef struct proto_param_value {
    uint32_t index; /* into the parameter table */
    double value;   /* validated: finite, in range, integral for int, 0/1 for bool */
} proto_param_value;

/* set_groom's "collider": absent = keep the current collision mesh, null = none, a name = that
 * mesh file. */
typedef enum proto_collider_mode { PROTO_COLLIDER_KEEP = 0, PROTO_COLLIDER_NONE, PROTO_COLLIDER_FILE } proto_collider_mode;

/* One parsed client message. */
/* What a client's stream carries (subscribe's "source"). */
typedef enum proto_source {
    PROTO_SOURCE_STRANDS = 0, /* the strands (codec "strand") */
    PROTO_SOURCE_HAIRMESH     /* the hair mesh's vertices (codec "hairmesh"), while the solver has one */
} proto_source;

/* The source's name in subscribe ("strands", "hairmesh"). Pure. */
const char *proto_source_name(proto_source s);

typedef struct proto_msg {
    proto_type type;
    proto_id id;
    union {
        struct {
            uint32_t count;
            proto_param_value v[PROTO_MAX_PARAMS];
        } set_params;
        struct {
            bool has_t;
            double t; /* client clock, ms */
            core_vec3 position;
            core_quat orientation; /* normalized */
        } motion;
        struct {
            uint32_t preset; /* index into the parser's preset names */
            double speed;
        } animate;
        struct {
            int32_t count;
        } step;
        struct {
            bool is_file;
            uint32_t style;       /* index into the parser's style names (procedural) */
            char file[PROTO_MAX_NAME + 1];
            uint32_t strands, verts; /* 0 = keep the current count */
            bool has_seed;
            uint64_t seed; /* 0..2^53-1 (exact in JSON); 0 = the groom module's default */
            proto_collider_mode collider_mode; /* the collision mesh of the new groom */
            char collider[PROTO_MAX_NAME + 1]; /* PROTO_COLLIDER_FILE: a name under the asset folder */
        } set_groom;
        struct {
            bool has_stride, has_max_error, has_max_rate, has_source;
            proto_source source;
            int32_t stride;
            double max_error;
            double max_rate;
        } subscribe;
        struct {
            char token[PROTO_MAX_TOKEN + 1];
        } auth;
    } u;
} proto_msg;

/* What proto_parse validates against; the caller owns every array (static tables). */
typedef struct proto_parser {
    const core_param_info *params;
    size_t nparams;                 /* at most PROTO_MAX_PARAMS */
    const char *const *presets;     /* animation preset names */
    size_t npresets;
    const char *const *styles;      /* procedural groom styles */
    size_t nstyles;
} proto_parser;

/* Parses one client text message (len bytes, need not be NUL-terminated) into *out.
 * On rejection returns CORE_EINVAL and fills *e; out->id holds the request id when it could be
 * read (so the error reply can echo it). Pure; any thread. */
core_status proto_parse(const proto_parser *p, const char *text, size_t len, proto_msg *out, proto_error *e);

/* Wire name of a code ("bad_json", ...) or of a message type ("set_params", ...). Static. */
const char *proto_code_name(proto_code code);
const char *proto_type_name(proto_type type);

/* Fills e and returns CORE_EINVAL. */
core_status proto_fail(proto_error *e, proto_code code, const char *field, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* ---- server -> client messages. Every builder returns a NUL-terminated string the caller
 * frees with proto_free, or NULL when out of memory. Pure; any thread. ---- */

void proto_free(char *text);

/* {"type":"error","id":..,"code":..,"field":..,"message":..} */
char *proto_build_error(const proto_id *id, const proto_error *e);

/* {"type":"ok","id":..,"request":"<type name>","step":..}: step (the simulation step from which a
 * change to the simulation shows, proto/PROTOCOL.md) only when step >= 0. */
char *proto_build_ok(const proto_id *id, proto_type request, int64_t step);

/* {"type":"params","id":..,"values":{..},"changed":[..],"by":..}: every value, read from the
 * struct at `values` through the table offsets (an announcement carries the whole state, so a
 * client's queue may keep only the newest one); "changed" names the entries with changed[i]
 * set, only when changed is non-NULL. by < 0 writes null (a reply to get_params or a
 * server-side change). Caller frees the result; any thread. */
char *proto_build_params(const proto_id *id, const core_param_info *table, size_t n, const void *values,
                         const bool *changed, int64_t by);

/* Where a client fetches the groom's collision mesh (the binary of proto_mesh_bin_write). */
typedef struct proto_mesh_ref {
    const char *source;           /* "ratboy/Ratboy_body.tfxmesh" (a name under the asset folder or the --collider file's name) */
    const char *url;              /* "/collider.bin" */
    const char *etag;             /* the binary's version: proto_bin_etag */
    uint64_t bytes;               /* the binary's size */
} proto_mesh_ref;

/* Where a client fetches the groom's per-strand data (the binary of proto_groom_bin_write). */
typedef struct proto_data_ref {
    const char *url;              /* "/groom.bin" */
    const char *etag;             /* the binary's version: proto_bin_etag */
    uint64_t bytes;               /* the binary's size */
} proto_data_ref;

/* Everything about the groom a client needs to draw it and decode frames. */
typedef struct proto_groom {
    const char *source;           /* "procedural:straight", "file:ratboy/Ratboy_mohawk.tfx" */
    const core_groom *groom;      /* rest pose, head frame; its mesh and sdf (when set) are described too */
    uint64_t seed;
    const proto_data_ref *data;   /* the rest lengths and roots (required) */
    const proto_mesh_ref *mesh;   /* required when groom->mesh is set, ignored otherwise */
    const proto_data_ref *hairmesh; /* the hair mesh topology binary (proto_hairmesh_bin_write):
                                       required when groom->hairmesh is set, ignored otherwise */
} proto_groom;

/* Pre-rendered JSON of a groom ("groom", "colliders" and "collider_mesh" values); built once
 * per groom and embedded in every hello and groom message. Free with proto_groom_json_free. */
typedef struct proto_groom_json {
    char *groom;
    char *colliders;
    char *mesh;                   /* "null" when the groom has no collision mesh */
} proto_groom_json;

core_status proto_groom_json_build(proto_groom_json *out, const proto_groom *g, core_err *err);
void proto_groom_json_free(proto_groom_json *j);

/* {"type":"groom","groom":{..},"colliders":[..],"collider_mesh":{..}|null} */
char *proto_build_groom(const proto_groom_json *g);

typedef struct proto_anim {
    const char *preset;
    double speed;
} proto_anim;

typedef struct proto_state {
    bool paused;
    double sim_time;
    uint64_t steps;
    proto_anim animation;
} proto_state;

/* {"type":"state","id":..,"paused":..,"sim_time":..,"steps":..,"animation":{..}} */
char *proto_build_state(const proto_id *id, const proto_state *s);

/* The stream a client receives. */
typedef struct proto_stream {
    const char *codec;     /* "strand", or "hairmesh" for a client subscribed to the hair mesh
                              (then stride is 1 and strands the mesh's columns) */
    int32_t stride;        /* every stride-th strand, starting with strand 0 */
    uint32_t strands;      /* strands per frame */
    double max_error;      /* m */
    double max_rate;       /* Hz the client asked for (0 = server rate) */
    double rate;           /* Hz the server publishes at */
    double frame_rate;     /* Hz of this client's stream: rate / its decimation */
    int32_t keyframe_interval; /* frames of the stream */
} proto_stream;

/* {"type":"subscribed","id":..,"stream":{..}} */
char *proto_build_subscribed(const proto_id *id, const proto_stream *s);

typedef struct proto_hello {
    const char *server;       /* "strandcastd" */
    const char *version;      /* "0.1.0" */
    uint32_t client;          /* this connection's client number (the "by" of its changes) */
    const proto_groom_json *groom;
    core_xform head;
    const core_param_info *params;
    size_t nparams;
    const void *values;       /* params struct read through the table offsets */
    const char *const *presets;
    size_t npresets;
    proto_anim animation;
    const char *const *styles;
    size_t nstyles;
    const char *const *files; /* groom files set_groom may name */
    size_t nfiles;
    const char *const *meshes; /* collision mesh files set_groom's collider may name */
    size_t nmeshes;
    proto_stream stream;
    proto_state state;
    bool token_required;      /* access "token": changes need an accepted auth first; else "open" */
    const char *room;         /* the room this connection is in (proto_room_valid); NULL = PROTO_DEFAULT_ROOM */
} proto_hello;

/* True when name is a room name: 1..PROTO_MAX_ROOM bytes of ASCII letters, digits, '-' and '_'
 * (so that it is one token of a NATS subject). Any thread. */
bool proto_room_valid(const char *name);

/* The room a WebSocket request path addresses: PROTO_ROOM_PREFIX "NAME" gives NAME (copied
 * into room, PROTO_MAX_ROOM + 1 bytes), any other path the default room. A path under the prefix
 * whose name is not a room name is PROTO_ERR_BAD_ROOM in *e (field "room"). Any thread. */
core_status proto_room_of_path(const char *path, char *room, proto_error *e);

/* The WebSocket request path of room (NULL or PROTO_DEFAULT_ROOM: "/", else PROTO_ROOM_PREFIX
 * "NAME") into path (cap bytes; PROTO_ROOM_PATH_MAX is enough). False when room is not a room name
 * (proto_room_valid) or path is too small. Any thread. */
bool proto_room_path(const char *room, char *path, size_t cap);

/* The first message of every connection; see proto/PROTOCOL.md. */
char *proto_build_hello(const proto_hello *h);

/* ---- the collision mesh binary (GET /collider.bin; layout in proto/PROTOCOL.md) ---- */
#define PROTO_MESH_MAGIC "SCMH"
#define PROTO_MESH_VERSION 1u
#define PROTO_MESH_HEADER 16u /* magic, version, nverts, ntris (uint32 LE each) */

/* Bytes of m's binary: PROTO_MESH_HEADER + 12 nverts + 12 ntris. Pure. */
size_t proto_mesh_bin_size(const core_mesh *m);
/* Writes m's binary (proto_mesh_bin_size bytes) to out. Pure, any thread. */
void proto_mesh_bin_write(const core_mesh *m, unsigned char *out);
/* Checks a binary of len bytes (magic, version, exact size, finite positions, indices in
 * range) and gives its counts; the positions start at bin + PROTO_MESH_HEADER, the indices
 * 12 nverts bytes later. CORE_EFORMAT with the reason in err. Pure, any thread. */
core_status proto_mesh_bin_read(const unsigned char *bin, size_t len, uint32_t *nverts, uint32_t *ntris, core_err *err);

/* ---- the groom data binary (GET /groom.bin; layout in proto/PROTOCOL.md) ---- */
#define PROTO_GROOM_MAGIC "SCGR"
#define PROTO_GROOM_VERSION 1u
#define PROTO_GROOM_HEADER 16u /* magic, version, nstrands, nverts (uint32 LE each) */

/* Bytes of g's binary: PROTO_GROOM_HEADER + 16 nstrands. Pure. */
size_t proto_groom_bin_size(const core_groom *g);
/* Writes g's binary (proto_groom_bin_size bytes) to out: each strand's rest segment length
 * (the mean over its segments of the rest pose), then its rest root. Pure, any thread. */
void proto_groom_bin_write(const core_groom *g, unsigned char *out);
/* Checks a binary of len bytes (magic, version, counts, exact size, finite non-negative
 * lengths, finite roots) and gives its counts; the rest lengths start at
 * bin + PROTO_GROOM_HEADER, the roots 4 nstrands bytes later. CORE_EFORMAT with the reason in
 * err. Pure, any thread. */
core_status proto_groom_bin_read(const unsigned char *bin, size_t len, uint32_t *nstrands, uint32_t *nverts, core_err *err);

/* ---- the hair mesh topology binary (GET /hairmesh.bin; layout in proto/PROTOCOL.md) ---- */
#define PROTO_HAIRMESH_MAGIC "SCHT"
#define PROTO_HAIRMESH_VERSION 1u
#define PROTO_HAIRMESH_HEADER 24u /* magic, version, ncols, nlayers, nfaces, nguides (uint32 LE each) */

/* The counts of a hair mesh topology binary. */
typedef struct proto_hairmesh_counts {
    uint32_t ncols, nlayers, nfaces, nguides;
} proto_hairmesh_counts;

/* Bytes of m's binary: PROTO_HAIRMESH_HEADER + 16 nfaces + 12 nguides + 12 ncols nlayers. Pure. */
size_t proto_hairmesh_bin_size(const core_hairmesh *m);
/* Writes m's binary (proto_hairmesh_bin_size bytes) to out: its faces, its guides' faces and
 * coordinates, then its rest vertices. Pure, any thread. */
void proto_hairmesh_bin_write(const core_hairmesh *m, unsigned char *out);
/* Checks a binary of len bytes (magic, version, counts, exact size, face corners in range and
 * distinct with a triangle's 4th CORE_HAIRMESH_NONE, guide faces in range, finite guide
 * coordinates and vertices) and gives its counts; the faces start at bin +
 * PROTO_HAIRMESH_HEADER. CORE_EFORMAT with the reason in err. Pure, any thread. */
core_status proto_hairmesh_bin_read(const unsigned char *bin, size_t len, proto_hairmesh_counts *out, core_err *err);

/* A served binary's version tag: 16 lowercase hex digits of its 64-bit FNV-1a hash, into out
 * (17 bytes with the NUL). Pure. */
void proto_bin_etag(const unsigned char *bin, size_t len, char out[17]);

typedef struct proto_stats {
    double steps_per_s;
    double step_ms;
    double encode_ms;
    uint32_t clients;
    double sim_time;
    uint64_t steps;
    uint64_t nan_resets;
} proto_stats;

/* {"type":"stats",..}: broadcast about once per second. */
char *proto_build_stats(const proto_stats *s);

/* ---- reading server messages (client tools) ---- */

/* The "type" of a message into type (cap bytes; "" when there is none) and its "id" into *id
 * (PROTO_ID_NONE when absent or not a finite number or a string of at most PROTO_MAX_ID bytes).
 * CORE_EFORMAT when text is not a JSON object with a string "type". Pure, any thread. */
core_status proto_read_envelope(const char *text, size_t len, char *type, size_t cap, proto_id *id);

/* True when two ids are the same (kind and value). Pure. */
bool proto_id_equal(const proto_id *a, const proto_id *b);

/* The "step" of an ok reply (the simulation step from which the change shows) into *step.
 * CORE_EFORMAT when text is not an ok or has no step that is a whole number in [0, 2^53]. Pure,
 * any thread. */
core_status proto_read_ok_step(const char *text, size_t len, uint64_t *step);

/* What a client tool shows of a hello; numbers are NaN where the hello lacks them. */
typedef struct proto_hello_info {
    char server[64], version[32], source[PROTO_MAX_NAME + 16];
    double protocol, client, strands, verts;
    double stride, max_error, rate, frame_rate; /* the client's stream */
} proto_hello_info;

/* Reads a hello into *out. CORE_EFORMAT (with the reason in err) when text is not a hello or
 * lacks the protocol version or the groom's counts. Pure, any thread. */
core_status proto_read_hello(const char *text, size_t len, proto_hello_info *out, core_err *err);

#endif
