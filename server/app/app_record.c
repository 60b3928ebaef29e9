/* app: the --record writer: a memory buffer on the sim thread, written out by its own thread. */
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <time.h>

#include "app_record.h"

/* Writes b to the file; on failure logs (the first time), counts, and drops it. Writer thread. */
static void write_out(app_record *r, app_rec_buf *b)
{
    if (!b->len) return;
    bool ok = !ferror(r->f) && fwrite(b->p, 1, b->len, r->f) == b->len && fflush(r->f) == 0;
    if (ok) {
        atomic_fetch_add(&r->bytes, b->len);
    } else if (atomic_fetch_add(&r->errors, 1) == 0) {
        core_log(CORE_LOG_ERROR, "record", "%s: write failed (%s); the simulation goes on, the recording is incomplete",
                 r->path, strerror(errno));
    }
    b->len = 0;
}

static void *writer_main(void *arg)
{
    app_record *r = arg;
    prctl(PR_SET_NAME, "sc-record");
    app_rec_buf out = { 0 };
    pthread_mutex_lock(&r->mu);
    for (;;) {
        struct timespec until;
        clock_gettime(CLOCK_MONOTONIC, &until);
        until.tv_nsec += APP_RECORD_FLUSH_MS * 1000000L;
        if (until.tv_nsec >= 1000000000L) until.tv_sec++, until.tv_nsec -= 1000000000L;
        while (!r->stop && pthread_cond_timedwait(&r->cv, &r->mu, &until) == 0) {}
        app_rec_buf t = r->pending; /* swap: the sim thread appends to the emptied one */
        r->pending = out;
        out = t;
        bool stop = r->stop;
        pthread_mutex_unlock(&r->mu);
        write_out(r, &out);
        pthread_mutex_lock(&r->mu);
        if (stop && !r->pending.len) break;
    }
    pthread_mutex_unlock(&r->mu);
    app_rec_buf_free(&out);
    return NULL;
}

/* Moves the encoded scratch record into the pending buffer. Sim thread. */
static void commit(app_record *r)
{
    if (r->scratch.oom) {
        atomic_fetch_add(&r->dropped, 1);
        app_rec_buf_free(&r->scratch);
        return;
    }
    pthread_mutex_lock(&r->mu);
    bool full = r->pending.len + r->scratch.len > APP_RECORD_MAX_PENDING;
    if (!full) {
        size_t before = r->pending.len;
        app_rec_buf *b = &r->pending;
        if (b->len + r->scratch.len > b->cap) {
            size_t cap = b->cap ? b->cap : 65536;
            while (cap < b->len + r->scratch.len) cap *= 2;
            uint8_t *p = realloc(b->p, cap);
            if (p) b->p = p, b->cap = cap;
        }
        if (b->len + r->scratch.len <= b->cap) {
            memcpy(b->p + b->len, r->scratch.p, r->scratch.len);
            b->len += r->scratch.len;
        }
        full = b->len == before;
    }
    pthread_mutex_unlock(&r->mu);
    if (full && atomic_fetch_add(&r->dropped, 1) == 0)
        core_log(CORE_LOG_ERROR, "record", "%s: records dropped (the disk does not keep up or memory ran out)", r->path);
    r->scratch.len = 0;
}

core_status app_record_open(app_record *r, const char *path, const app_rec_start *s, const proto_parser *p,
                            bool digests, core_err *err)
{
    memset(r, 0, sizeof *r);
    snprintf(r->path, sizeof r->path, "%s", path);
    r->parser = p;
    r->digests = digests;
    if (!(r->f = fopen(path, "wb"))) return core_fail(err, CORE_EIO, "--record %s: %s", path, strerror(errno));
    app_rec_put_file_header(&r->pending); /* written by the thread, like every record */
    app_rec_put_start(&r->pending, s, p->params, p->nparams);
    if (r->pending.oom) {
        fclose(r->f);
        app_rec_buf_free(&r->pending);
        return core_fail(err, CORE_ENOMEM, "--record %s: out of memory", path);
    }
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_mutex_init(&r->mu, NULL);
    pthread_cond_init(&r->cv, &ca);
    pthread_condattr_destroy(&ca);
    if (pthread_create(&r->thread, NULL, writer_main, r) != 0) {
        fclose(r->f);
        r->f = NULL;
        return core_fail(err, CORE_EBACKEND, "--record %s: cannot start the writer thread", path);
    }
    r->started = true;
    core_log(CORE_LOG_INFO, "record", "recording to %s%s", path, digests ? " (with a position digest per step)" : "");
    return CORE_OK;
}

void app_record_input(app_record *r, uint64_t step, const proto_msg *m)
{
    if (!r || !r->started) return;
    app_rec_put_input(&r->scratch, step, m, r->parser);
    commit(r);
}

void app_record_digest(app_record *r, uint64_t step, uint64_t digest)
{
    if (!r || !r->started) return;
    app_rec_put_digest(&r->scratch, step, digest);
    commit(r);
}

void app_record_close(app_record *r, uint64_t step)
{
    if (!r->started) return;
    app_rec_put_end(&r->scratch, step);
    commit(r);
    pthread_mutex_lock(&r->mu);
    r->stop = true;
    pthread_cond_signal(&r->cv);
    pthread_mutex_unlock(&r->mu);
    pthread_join(r->thread, NULL);
    bool ok = fclose(r->f) == 0 && !atomic_load(&r->errors) && !atomic_load(&r->dropped);
    if (ok)
        core_log(CORE_LOG_INFO, "record", "%s: %llu bytes, %llu steps", r->path, (unsigned long long)atomic_load(&r->bytes),
                 (unsigned long long)step);
    else
        core_log(CORE_LOG_ERROR, "record", "%s is incomplete: %llu failed writes, %llu records dropped", r->path,
                 (unsigned long long)atomic_load(&r->errors), (unsigned long long)atomic_load(&r->dropped));
    app_rec_buf_free(&r->pending);
    app_rec_buf_free(&r->scratch);
    pthread_mutex_destroy(&r->mu);
    pthread_cond_destroy(&r->cv);
    r->started = false;
}
