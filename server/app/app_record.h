/* app: the --record writer: the sim thread appends records to a memory buffer (no I/O); a
 * writer thread writes them out every APP_RECORD_FLUSH_MS and at the end. A write error is
 * logged once and counted (record_errors in /metrics); the simulation goes on, the records
 * after it are dropped. Owns the file and the thread. */
#ifndef APP_RECORD_H
#define APP_RECORD_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>

#include "app_rec.h"

#define APP_RECORD_FLUSH_MS 200
#define APP_RECORD_MAX_PENDING (64u << 20) /* bytes waiting for the disk; past it records are dropped */

typedef struct app_record {
    FILE *f;
    char path[APP_REC_MAX_PATH];
    const proto_parser *parser;
    bool digests;             /* a digest record after every step */
    pthread_t thread;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    app_rec_buf pending;      /* sim thread appends, writer takes (under mu) */
    app_rec_buf scratch;      /* sim thread: one record being encoded */
    bool stop, started;
    atomic_uint_fast64_t bytes, errors, dropped; /* written, failed writes, records dropped */
} app_record;

/* Creates path (truncating it), queues the header and the start record and starts the writer
 * thread. CORE_EIO (path cannot be created) / CORE_ENOMEM with err naming the file; later write
 * errors are counted, not returned. Main thread, before the sim thread. */
core_status app_record_open(app_record *r, const char *path, const app_rec_start *s, const proto_parser *p,
                            bool digests, core_err *err);
/* Appends an input applied before the step after `step` steps. Sim thread; never blocks on I/O. */
void app_record_input(app_record *r, uint64_t step, const proto_msg *m);
/* Appends the digest of the positions after `step` steps. Sim thread. */
void app_record_digest(app_record *r, uint64_t step, uint64_t digest);
/* Appends the end record (after `step` steps), writes everything, stops the thread and closes
 * the file; logs the outcome. Main thread, after the sim thread ended. Safe on a zeroed r. */
void app_record_close(app_record *r, uint64_t step);

#endif
