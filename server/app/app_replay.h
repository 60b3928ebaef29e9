/* app: the --replay player: reads and checks a whole recording before the daemon starts
 * (format, fields, the files it names), then hands the sim thread each input at its step and
 * checks the position digests. Owns the records. */
#ifndef APP_REPLAY_H
#define APP_REPLAY_H

#include "app_assets.h"
#include "app_rec.h"

#define APP_REPLAY_CLIENT 0xfffffffeu /* the client id replayed inputs are carried out as (no replies) */

typedef struct app_replay {
    char path[APP_REC_MAX_PATH];
    app_rec_start start;      /* the initial state */
    app_rec *recs;            /* inputs, digests, then the end record */
    size_t n, next;           /* next: the first record not handed out yet */
    uint64_t end_step;        /* the recording stopped after this many steps */
    uint64_t digests, inputs; /* checked and applied so far */
    bool active;              /* the sim thread is replaying (until the end step) */
} app_replay;

/* Reads path and checks it; the groom and collider files of the start record must exist, and
 * every set_groom's file and collider must be in the asset list (of assets_dir). CORE_EFORMAT / CORE_EIO /
 * CORE_ENOMEM with err naming the file, the byte offset, the record and the field. Main thread. */
core_status app_replay_open(app_replay *r, const char *path, const proto_parser *p, const app_assets *as,
                            const char *assets_dir, core_err *err);
/* The next input due before the step after `step` steps (advancing past it), or NULL. Sim thread. */
const proto_msg *app_replay_input(app_replay *r, uint64_t step);
/* Compares the positions' digest after `step` steps with the recorded one, if any: false (err
 * saying where) when they differ. Sim thread. */
bool app_replay_check(app_replay *r, uint64_t step, uint64_t digest, core_err *err);
/* Frees the records (safe on a zeroed or failed r). Main thread, after the sim thread ended. */
void app_replay_free(app_replay *r);

#endif
