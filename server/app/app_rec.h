/* app: the record file format (proto/RECORD.md): byte encoding of the initial state, the
 * inputs, the position digests and the end mark (app_rec_write.c), and their checked decoding
 * (app_rec_read.c). Pure functions; the writer (app_record) and the player (app_replay) own the
 * files. */
#ifndef APP_REC_H
#define APP_REC_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "core/core.h"
#include "proto/proto.h"
#include "sim/sim.h"

#define APP_REC_MAGIC "SCREC\r\n\x1a" /* 8 bytes: text tools and line-end mangling show as corrupt */
#define APP_REC_MAGIC_LEN 8
#define APP_REC_VERSION 1u
#define APP_REC_FILE_HEADER 12        /* magic + u32 version */
#define APP_REC_FRAME 13              /* u32 length, u8 kind, u64 step, then payload, then u32 crc32 */
#define APP_REC_MAX_PAYLOAD (1u << 20)
#define APP_REC_MAX_PATH 1024

typedef enum app_rec_kind {
    APP_REC_START = 1,  /* the initial state; the first record, once */
    APP_REC_INPUT = 2,  /* a change applied before the step after `step` steps */
    APP_REC_DIGEST = 3, /* the positions after `step` steps (--record-digests) */
    APP_REC_END = 4,    /* the recording stopped after `step` steps; the last record */
} app_rec_kind;

/* The initial state: what strandcastd was started with, and every simulation parameter. */
typedef struct app_rec_start {
    char groom[APP_REC_MAX_PATH];    /* style name or groom file path, as given */
    char collider[APP_REC_MAX_PATH]; /* collision mesh path; "" = none */
    uint32_t strands, verts;         /* as given (0 = default) */
    uint64_t seed;
    uint32_t backend;                /* sim_backend_kind the daemon resolved */
    int32_t threads;
    sim_params params;               /* every parameter (dt included), by name in the file */
} app_rec_start;

/* A growing byte buffer; oom set (and later appends ignored) when it cannot grow. */
typedef struct app_rec_buf {
    uint8_t *p;
    size_t len, cap;
    bool oom;
} app_rec_buf;

/* Frees b's bytes and zeroes it (the caller owns b). Any thread. */
void app_rec_buf_free(app_rec_buf *b);
/* The file header (magic, version) into b. */
void app_rec_put_file_header(app_rec_buf *b);
/* One record of each kind appended to b (framed, crc32 over kind, step and payload). Pure. */
void app_rec_put_start(app_rec_buf *b, const app_rec_start *s, const core_param_info *table, size_t n);
void app_rec_put_input(app_rec_buf *b, uint64_t step, const proto_msg *m, const proto_parser *p);
void app_rec_put_digest(app_rec_buf *b, uint64_t step, uint64_t digest);
void app_rec_put_end(app_rec_buf *b, uint64_t step);

/* The 64-bit digest of n positions (their bits: equal digests <=> equal bits, but for
 * collisions). Pure. */
uint64_t app_rec_digest(const float *xyz, size_t n);

/* One decoded record. */
typedef struct app_rec {
    app_rec_kind kind;
    uint64_t step;
    uint32_t index;       /* 0 = the start record */
    size_t offset;        /* its first byte in the file */
    proto_msg msg;        /* APP_REC_INPUT */
    uint64_t digest;      /* APP_REC_DIGEST */
} app_rec;

/* Reads a whole file's bytes: the header, the start record into *s, then every record into
 * *out (malloc'd, *n of them; the caller frees), checking the version, the framing, each crc32,
 * each field (parameter, preset and style names against the tables), the order of steps, and
 * the end record last. CORE_EINVAL with err naming the byte offset, the record and the field.
 * Pure. */
core_status app_rec_read(const uint8_t *data, size_t len, const proto_parser *p, app_rec_start *s, app_rec **out,
                         size_t *n, core_err *err);

#endif
