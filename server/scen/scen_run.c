/* scen: runs a scenario script against a daemon over one WebSocket connection: sends messages at
 * their time, matches replies by id, decodes frames, checks expectations and invariants. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../net/net.h"
#include "../proto/proto.h"
#include "../wsc/wsc.h"
#include "scen.h"

#define SCEN_CONNECT_MS 5000
#define SCEN_SLICE_MS 20
#define SCEN_METRICS_MS 100 /* expect "metrics": /metrics is fetched at most this often while a step waits */

/* A received text message that may answer a request. */
typedef struct scen_msg {
    char *text; /* owned by the connection */
    char type[32];
    proto_id id;
    bool used;
} scen_msg;

/* A binary message received and not yet taken. */
typedef struct queued_frame {
    uint8_t *data; /* owned */
    size_t len;
    size_t ntexts;                  /* text messages received before it */
    unsigned long long arrival_ns;  /* monotonic */
} queued_frame;

typedef struct runner {
    const scen_run_desc *d;
    FILE *out;
    wsc *w;
    wsc_conn *conn;
    scen_world world;
    bool have_world;
    codec_decoder dec;
    float *xyz;
    size_t cap;
    unsigned long long t0;
    unsigned long frames;
    codec_frame_info last; /* the last decoded frame */
    bool have_frame;
    /* a reset this client sent, until a frame of the restarted simulation arrives: frames sent
     * before the reset took effect may come after its reply and its state announcement. A reset
     * restarts the step counter at 0 (its ok carries step 0) and sends that rest pose at once:
     * the first frame at step 0 or below every earlier one's step ends it */
    bool reset_pending;
    uint64_t reset_max_step;
    const char *host; /* where the hello came from: the groom data is fetched there */
    int port;
    size_t hello_at; /* the hello's index among the connection's text messages */
    /* binary messages as they arrive (on_frame), taken in order with the text messages outside
     * lws callbacks (take_messages): a groom message's data is fetched on the same wsc */
    queued_frame *queue;
    size_t qhead, qlen, qcap;
    char fatal[CORE_ERR_MAX + 64]; /* what ends the script: a frame that does not decode, groom data not fetched */
    size_t next_text;
    scen_msg *msgs;
    size_t nmsgs, cap_msgs;
    scen_check *check; /* the check in progress, or NULL */
    cJSON *frame_json; /* the last frame's header as JSON, for expect "frame" (rebuilt when asked) */
    cJSON *metric_json;          /* expect "metrics": the sample last read (NULL: absent) */
    unsigned long long metric_ns; /* when /metrics was last fetched (0: never) */
    /* the step in progress: its result */
    char detail[1024];
    char *seen; /* JSON text of what was seen (owned), or NULL */
} runner;

static double elapsed_s(const runner *r) { return (double)(core_now_ns() - r->t0) / 1e9; }

static bool is_reply_type(const char *t)
{
    return !strcmp(t, "ok") || !strcmp(t, "error") || !strcmp(t, "params") || !strcmp(t, "state") ||
           !strcmp(t, "subscribed");
}

/* After a reset (a state whose steps are below the last frame's) or a groom change, the last
 * frame no longer tells the sim time or step: at_* and until_* wait for a frame that follows. */
static void forget_stale_frame(runner *r, const char *type)
{
    if (!r->have_frame) return;
    if (!strcmp(type, "groom")) r->have_frame = false;
    const cJSON *t = strcmp(type, "state") ? NULL : scen_world_value(&r->world, "state", "steps");
    if (cJSON_IsNumber(t) && t->valuedouble < (double)r->last.sim.sim_step) r->have_frame = false;
}

/* scen_fetch_fn over HTTP: GET url from the host and port of the hello. */
static core_status fetch_http(void *user, const char *url, size_t max_bytes, uint8_t **body, size_t *len, core_err *err)
{
    runner *r = user;
    *body = NULL;
    *len = 0;
    wsc_http_desc d = { .host = r->host, .port = r->port, .path = url, .max_bytes = max_bytes, .timeout_ms = SCEN_CONNECT_MS };
    wsc_http_reply rep;
    if (!wsc_http_get(r->w, &d, &rep))
        return core_fail(err, CORE_EIO, "groom data: GET http://%s:%d%.200s: %s", r->host, r->port, url, rep.error);
    if (rep.status != 200) {
        wsc_http_reply_free(&rep);
        return core_fail(err, CORE_EIO, "groom data: GET http://%s:%d%.200s answered %d", r->host, r->port, url, rep.status);
    }
    *body = rep.body;
    *len = rep.len;
    return CORE_OK;
}

/* Takes the text messages received since the last call up to index limit, in order: the world
 * learns from them and the replies are kept for matching. */
static void drain_texts(runner *r, size_t limit)
{
    size_t n;
    char *const *t = wsc_texts(r->conn, &n);
    if (limit < n) n = limit;
    for (; r->next_text < n; r->next_text++) {
        const char *text = t[r->next_text];
        char type[32];
        proto_id id;
        if (proto_read_envelope(text, strlen(text), type, sizeof type, &id) != CORE_OK) continue;
        if (strcmp(type, "stats") == 0) continue;
        core_err err;
        if (scen_world_text(&r->world, text, &err) != CORE_OK && !r->fatal[0])
            snprintf(r->fatal, sizeof r->fatal, "%s", err.msg);
        t = wsc_texts(r->conn, &n); /* a groom data fetch ran the connection: more may have come */
        if (limit < n) n = limit;
        forget_stale_frame(r, type);
        if (!is_reply_type(type)) continue;
        if (r->nmsgs == r->cap_msgs) {
            size_t cap = r->cap_msgs ? 2 * r->cap_msgs : 64;
            scen_msg *m = realloc(r->msgs, cap * sizeof *m);
            if (!m) continue;
            r->msgs = m;
            r->cap_msgs = cap;
        }
        scen_msg *m = &r->msgs[r->nmsgs++];
        m->text = (char *)text;
        snprintf(m->type, sizeof m->type, "%s", type);
        m->id = id;
        m->used = false;
    }
}

/* Decodes one frame and, once the hello is read and the frame came after it, checks it. */
static void take_frame(runner *r, const queued_frame *q)
{
    codec_frame_info info;
    core_err err;
    if (codec_peek_header(q->data, q->len, &info, &err) != CORE_OK) goto bad;
    size_t need = 3u * (size_t)info.nstrands_sent * info.nverts;
    if (need > r->cap) {
        float *x = realloc(r->xyz, need * sizeof *x);
        if (!x) {
            core_fail(&err, CORE_ENOMEM, "out of memory for %zu positions", need);
            goto bad;
        }
        r->xyz = x;
        r->cap = need;
    }
    /* frames that came before the hello are decoded too: the decoder keeps their keyframe */
    if (codec_decode(&r->dec, q->data, q->len, r->xyz, r->cap, &info, &err) != CORE_OK) goto bad;
    if (q->ntexts <= r->hello_at) return;
    if (r->reset_pending) {
        if (info.sim.sim_step != 0 && info.sim.sim_step >= r->reset_max_step) {
            r->reset_max_step = info.sim.sim_step;
            return;
        }
        r->reset_pending = false;
    }
    r->last = info;
    r->have_frame = true;
    r->frames++;
    if (r->check) scen_check_frame(r->check, &r->world, &info, r->xyz, q->arrival_ns);
    return;
bad:
    snprintf(r->fatal, sizeof r->fatal, "frame %lu does not decode: %s", r->frames, err.msg);
}

/* Takes every message received so far in the order it came: each frame after the text
 * messages before it, so that a frame is judged with every message the server sent before it.
 * Runs outside lws callbacks (a groom message fetches its data on r->w). Once the hello is read. */
static void take_messages(runner *r)
{
    while (r->qhead < r->qlen) { /* the queue may grow while a frame's texts are taken */
        queued_frame q = r->queue[r->qhead++];
        drain_texts(r, q.ntexts);
        if (!r->fatal[0]) take_frame(r, &q);
        free(q.data);
    }
    r->qhead = r->qlen = 0;
    drain_texts(r, SIZE_MAX);
}

static void on_frame(wsc_conn *conn, const uint8_t *data, size_t len, void *user)
{
    runner *r = user;
    if (r->fatal[0]) return;
    if (r->qlen == r->qcap) {
        size_t cap = r->qcap ? 2 * r->qcap : 16;
        queued_frame *q = realloc(r->queue, cap * sizeof *q);
        if (!q) {
            snprintf(r->fatal, sizeof r->fatal, "out of memory for %zu queued frames", cap);
            return;
        }
        r->queue = q;
        r->qcap = cap;
    }
    uint8_t *copy = malloc(len ? len : 1);
    if (!copy) {
        snprintf(r->fatal, sizeof r->fatal, "out of memory for a %zu-byte frame", len);
        return;
    }
    memcpy(copy, data, len);
    size_t ntexts;
    wsc_texts(conn, &ntexts);
    r->queue[r->qlen++] = (queued_frame){ copy, len, ntexts, core_now_ns() };
}

/* A condition a step waits for. */
typedef bool (*cond_fn)(runner *r, const scen_step *st, void *arg);

typedef struct wait_arg {
    runner *r;
    const scen_step *st;
    cond_fn cond;
    void *arg;
    bool met;
} wait_arg;

static bool poll_cond(void *p)
{
    wait_arg *a = p;
    if (a->met) return true; /* a condition may consume what it found (a reply): asked once */
    take_messages(a->r);
    a->met = a->cond(a->r, a->st, a->arg);
    return a->met || !wsc_is_open(a->r->conn) || a->r->fatal[0];
}

/* Runs the connection until cond holds (true), or timeout_ms passes, the connection closes or a
 * frame fails to decode (false, with the reason in r->detail unless it timed out). */
static bool wait_until(runner *r, const scen_step *st, cond_fn cond, void *arg, double timeout_ms)
{
    wait_arg a = { r, st, cond, arg, false };
    unsigned long long end = core_now_ns() + (unsigned long long)(timeout_ms * 1e6);
    for (;;) {
        if (poll_cond(&a)) break;
        unsigned long long now = core_now_ns();
        if (now >= end) return false;
        double left = (double)(end - now) / 1e6;
        wsc_until(r->w, poll_cond, &a, left < SCEN_SLICE_MS ? (int)ceil(left) : SCEN_SLICE_MS);
    }
    if (a.met) return true;
    if (r->fatal[0]) snprintf(r->detail, sizeof r->detail, "%s", r->fatal);
    else
        snprintf(r->detail, sizeof r->detail, "the server closed the connection (%d %s)", wsc_close_code(r->conn),
                 wsc_close_reason(r->conn));
    return false;
}

static void set_seen(runner *r, const char *text)
{
    free(r->seen);
    r->seen = text ? strdup(text) : NULL;
}

/* ---- conditions ---- */

static bool at_time(runner *r, const scen_step *st, void *arg)
{
    (void)arg;
    if (st->at_ms >= 0) return elapsed_s(r) * 1e3 >= st->at_ms;
    if (!r->have_frame) return false;
    if (st->at_sim_time >= 0) return r->last.sim.sim_time >= st->at_sim_time;
    if (st->at_step >= 0) return (double)r->last.sim.sim_step >= st->at_step;
    return true;
}

static bool id_matches(const scen_step *st, const proto_id *id)
{
    if (st->id_kind == 0) return id->kind == PROTO_ID_NONE;
    if (st->id_kind == 1) return id->kind == PROTO_ID_NUMBER && id->num == st->id_num;
    return id->kind == PROTO_ID_STRING && strcmp(id->str, st->id_str) == 0;
}

static bool got_reply(runner *r, const scen_step *st, void *arg)
{
    scen_msg **found = arg;
    for (size_t i = 0; i < r->nmsgs; i++) {
        scen_msg *m = &r->msgs[i];
        if (m->used || !id_matches(st, &m->id)) continue;
        /* without an id only ok, error and subscribed answer a request: params and state are broadcasts */
        if (st->id_kind == 0 && (!strcmp(m->type, "params") || !strcmp(m->type, "state"))) continue;
        m->used = true;
        *found = m;
        return true;
    }
    return false;
}

static bool frames_reached(runner *r, const scen_step *st, void *arg)
{
    (void)st;
    return r->frames >= *(const unsigned long *)arg;
}

static bool sim_time_reached(runner *r, const scen_step *st, void *arg)
{
    (void)arg;
    return r->have_frame && r->last.sim.sim_time >= st->count;
}

static bool step_reached(runner *r, const scen_step *st, void *arg)
{
    (void)arg;
    return r->have_frame && (double)r->last.sim.sim_step >= st->count;
}

static bool never(runner *r, const scen_step *st, void *arg)
{
    (void)r;
    (void)st;
    (void)arg;
    return false;
}

/* Whether a and b are equal, numbers within tol (arrays and objects member by member). */
static bool json_close(const cJSON *a, const cJSON *b, double tol)
{
    if (cJSON_IsNumber(a) && cJSON_IsNumber(b)) return fabs(a->valuedouble - b->valuedouble) <= tol;
    if (cJSON_IsArray(a) && cJSON_IsArray(b)) {
        if (cJSON_GetArraySize(a) != cJSON_GetArraySize(b)) return false;
        for (const cJSON *x = a->child, *y = b->child; x && y; x = x->next, y = y->next)
            if (!json_close(x, y, tol)) return false;
        return true;
    }
    if (cJSON_IsObject(a) && cJSON_IsObject(b)) {
        if (cJSON_GetArraySize(a) != cJSON_GetArraySize(b)) return false;
        for (const cJSON *x = a->child; x; x = x->next)
            if (!json_close(x, cJSON_GetObjectItemCaseSensitive(b, x->string), tol)) return false;
        return true;
    }
    return a && b && cJSON_Compare(a, b, true);
}

/* The value at path in what: the world's, or for "frame" the last frame's header (seq,
 * sim_time, step, head_position, head_orientation, keyframe, strands, strands_total, verts,
 * stride, max_error). */
/* The value of the sample named `name` (with its labels as the server prints them, e.g.
 * strandcast_control_messages_total{result="accepted"}) in a Prometheus text body; false when
 * no line carries it. */
static bool metric_sample(const char *body, size_t len, const char *name, double *out)
{
    const size_t n = strlen(name);
    for (const char *line = body, *end = body + len; line < end;) {
        const char *eol = memchr(line, '\n', (size_t)(end - line));
        if (!eol) eol = end;
        if (line[0] != '#' && (size_t)(eol - line) > n && !memcmp(line, name, n) && line[n] == ' ') {
            char num[64];
            size_t k = (size_t)(eol - line) - n - 1;
            if (k >= sizeof num) return false;
            memcpy(num, line + n + 1, k);
            num[k] = '\0';
            char *stop;
            *out = strtod(num, &stop);
            return stop != num && *stop == '\0';
        }
        line = eol + 1;
    }
    return false;
}

/* expect "metrics": GETs /metrics from the daemon (at most every SCEN_METRICS_MS while a step
 * waits) and keeps the sample named path as a JSON number. */
static const cJSON *metric_of(runner *r, const char *path)
{
    unsigned long long now = core_now_ns();
    if (r->metric_ns && now - r->metric_ns < (unsigned long long)SCEN_METRICS_MS * 1000000ull) return r->metric_json;
    r->metric_ns = now;
    cJSON_Delete(r->metric_json);
    r->metric_json = NULL;
    wsc_http_desc d = { .host = r->host, .port = r->port, .path = "/metrics", .timeout_ms = SCEN_CONNECT_MS };
    wsc_http_reply rep;
    if (!wsc_http_get(r->w, &d, &rep)) {
        snprintf(r->fatal, sizeof r->fatal, "GET http://%s:%d/metrics: %s", r->host, r->port, rep.error);
        return NULL;
    }
    double v;
    if (rep.status == 200 && rep.body && metric_sample((const char *)rep.body, rep.len, path, &v))
        r->metric_json = cJSON_CreateNumber(v);
    wsc_http_reply_free(&rep);
    return r->metric_json;
}

static const cJSON *value_of(runner *r, const char *what, const char *path)
{
    if (!strcmp(what, "metrics")) return metric_of(r, path);
    if (strcmp(what, "frame") != 0) return scen_world_value(&r->world, what, path);
    if (!r->have_frame) return NULL;
    cJSON_Delete(r->frame_json);
    cJSON *o = r->frame_json = cJSON_CreateObject();
    const codec_frame_info *f = &r->last;
    cJSON_AddNumberToObject(o, "seq", (double)f->seq);
    cJSON_AddNumberToObject(o, "sim_time", f->sim.sim_time);
    cJSON_AddNumberToObject(o, "step", (double)f->sim.sim_step);
    cJSON_AddItemToObject(o, "head_position", cJSON_CreateFloatArray(f->sim.head_pos, 3));
    cJSON_AddItemToObject(o, "head_orientation", cJSON_CreateFloatArray(f->sim.head_rot, 4));
    cJSON_AddBoolToObject(o, "keyframe", f->keyframe);
    cJSON_AddNumberToObject(o, "strands", f->nstrands_sent);
    cJSON_AddNumberToObject(o, "strands_total", f->nstrands_total);
    cJSON_AddNumberToObject(o, "verts", f->nverts);
    cJSON_AddNumberToObject(o, "stride", f->stride);
    cJSON_AddNumberToObject(o, "max_error", f->max_error_m);
    return cJSON_GetObjectItemCaseSensitive(o, path);
}

static bool value_holds(runner *r, const scen_step *st, void *arg)
{
    const cJSON *want = arg;
    const cJSON *v = value_of(r, st->what, st->path);
    if (!v) return false;
    if (want && !json_close(v, want, st->tolerance)) return false;
    if (!isnan(st->min) && !(cJSON_IsNumber(v) && v->valuedouble >= st->min)) return false;
    if (!isnan(st->max) && !(cJSON_IsNumber(v) && v->valuedouble <= st->max)) return false;
    return true;
}

static bool check_done(runner *r, const scen_step *st, void *arg)
{
    const unsigned long long *end_ns = arg;
    if (st->seconds > 0) return core_now_ns() >= *end_ns;
    return r->check->frames >= (unsigned long)st->count;
}

/* ---- steps ---- */

/* A reset sent with frames seen: the last frame no longer tells the sim time or step, and
 * frames from before the reset are told apart by their step (runner.reset_pending). */
static void note_reset(runner *r, const char *text)
{
    char type[32];
    proto_id id;
    if (!r->have_frame || proto_read_envelope(text, strlen(text), type, sizeof type, &id) != CORE_OK) return;
    if (strcmp(type, "reset") != 0) return;
    r->reset_pending = true;
    r->reset_max_step = r->last.sim.sim_step;
    r->have_frame = false;
}

static bool run_send(runner *r, const scen_step *st)
{
    double timeout = st->at_ms >= 0 ? st->at_ms + st->timeout_ms : st->timeout_ms;
    if (!wait_until(r, st, at_time, NULL, timeout)) {
        if (!r->detail[0])
            snprintf(r->detail, sizeof r->detail, "the simulation did not reach %s %g in %g ms (last frame: sim_time %.4f)",
                     st->at_sim_time >= 0 ? "sim_time" : "step", st->at_sim_time >= 0 ? st->at_sim_time : st->at_step,
                     st->timeout_ms, r->have_frame ? r->last.sim.sim_time : -1.0);
        return false;
    }
    wsc_send_text(r->conn, st->text);
    note_reset(r, st->text);
    snprintf(r->detail, sizeof r->detail, "sent %.900s", st->text);
    return true;
}

static bool run_reply(runner *r, const scen_step *st)
{
    scen_msg *m = NULL;
    char id[80];
    if (st->id_kind == 0) snprintf(id, sizeof id, "without an id");
    else if (st->id_kind == 1) snprintf(id, sizeof id, "to id %g", st->id_num);
    else snprintf(id, sizeof id, "to id \"%s\"", st->id_str);
    if (!wait_until(r, st, got_reply, &m, st->timeout_ms)) {
        if (!r->detail[0]) snprintf(r->detail, sizeof r->detail, "no reply %s in %g ms", id, st->timeout_ms);
        return false;
    }
    set_seen(r, m->text);
    cJSON *j = cJSON_Parse(m->text);
    const cJSON *code = cJSON_GetObjectItemCaseSensitive(j, "code"), *field = cJSON_GetObjectItemCaseSensitive(j, "field");
    const char *c = cJSON_IsString(code) ? code->valuestring : "", *f = cJSON_IsString(field) ? field->valuestring : "";
    char got[192], want[192];
    if (!strcmp(m->type, "error")) snprintf(got, sizeof got, "error %.40s, field \"%.96s\"", c, f);
    else snprintf(got, sizeof got, "%s", m->type);
    bool ok;
    if (st->error[0]) {
        ok = !strcmp(m->type, "error") && !strcmp(c, st->error) && (!st->field_given || !strcmp(f, st->field));
        int n = snprintf(want, sizeof want, "error %s", st->error);
        if (st->field_given) snprintf(want + n, sizeof want - (size_t)n, ", field \"%.96s\"", st->field);
    } else if (st->reply_type[0]) {
        ok = !strcmp(m->type, st->reply_type);
        snprintf(want, sizeof want, "%s", st->reply_type);
    } else {
        ok = strcmp(m->type, "error") != 0;
        snprintf(want, sizeof want, "any reply but an error");
    }
    snprintf(r->detail, sizeof r->detail, "reply %s: %s%s%s%s", id, got, ok ? "" : " (want ", ok ? "" : want, ok ? "" : ")");
    cJSON_Delete(j);
    return ok;
}

static bool run_wait(runner *r, const scen_step *st)
{
    bool ok;
    switch (st->kind) {
    case SCEN_FRAMES: {
        unsigned long target = r->frames + (unsigned long)st->count;
        ok = wait_until(r, st, frames_reached, &target, st->timeout_ms);
        if (!r->detail[0])
            snprintf(r->detail, sizeof r->detail, "%s %g frames (%lu in all)%s", ok ? "got" : "did not get", st->count,
                     r->frames, ok ? "" : " in time");
        return ok;
    }
    case SCEN_UNTIL_SIM_TIME:
        ok = wait_until(r, st, sim_time_reached, NULL, st->timeout_ms);
        break;
    case SCEN_UNTIL_STEP:
        ok = wait_until(r, st, step_reached, NULL, st->timeout_ms);
        break;
    default: /* SCEN_SLEEP: only a closed connection or a bad frame ends it early */
        wait_until(r, st, never, NULL, st->count);
        if (r->detail[0]) return false;
        snprintf(r->detail, sizeof r->detail, "slept %g ms", st->count);
        return true;
    }
    if (!r->detail[0])
        snprintf(r->detail, sizeof r->detail, "%s (last frame: sim_time %.4f, step %.0f)",
                 ok ? "reached" : "not reached in time", r->have_frame ? r->last.sim.sim_time : -1.0,
                 r->have_frame ? (double)r->last.sim.sim_step : -1.0);
    return ok;
}

static bool run_expect(runner *r, const scen_step *st)
{
    cJSON *want = st->equals ? cJSON_Parse(st->equals) : NULL;
    r->metric_ns = 0; /* each step starts from a fresh /metrics */
    bool ok = wait_until(r, st, value_holds, want, st->timeout_ms);
    const cJSON *v = value_of(r, st->what, st->path);
    char *seen = v ? cJSON_PrintUnformatted(v) : NULL;
    set_seen(r, seen);
    if (!r->detail[0]) {
        char wanted[512];
        int n = snprintf(wanted, sizeof wanted, "%.300s", st->equals ? st->equals : "");
        if (st->tolerance > 0) n += snprintf(wanted + n, sizeof wanted - (size_t)n, " within %g", st->tolerance);
        if (!isnan(st->min) || !isnan(st->max))
            snprintf(wanted + n, sizeof wanted - (size_t)n, "%sin [%g, %g]", n ? " " : "",
                     isnan(st->min) ? -INFINITY : st->min, isnan(st->max) ? INFINITY : st->max);
        snprintf(r->detail, sizeof r->detail, "%s.%s = %.300s (want %s)", st->what, st->path, seen ? seen : "(absent)",
                 wanted);
    }
    cJSON_free(seen);
    cJSON_Delete(want);
    return ok;
}

static bool run_check(runner *r, const scen_step *st)
{
    scen_check chk;
    scen_check_begin(&chk, &st->check);
    r->check = &chk;
    unsigned long long end_ns = core_now_ns() + (unsigned long long)(st->seconds * 1e9);
    double timeout = st->seconds > 0 ? st->seconds * 1e3 + 1000.0 : st->timeout_ms;
    bool done = wait_until(r, st, check_done, &end_ns, timeout);
    r->check = NULL;
    char figures[768];
    scen_check_json(&chk, figures, sizeof figures);
    char *seen = malloc(strlen(figures) + 3);
    if (seen) sprintf(seen, "{%s}", figures);
    free(r->seen);
    r->seen = seen;
    if (!done) {
        if (!r->detail[0])
            snprintf(r->detail, sizeof r->detail, "%lu of %g frames in %g ms", chk.frames, st->count, timeout);
        return false;
    }
    if (chk.frames == 0) {
        snprintf(r->detail, sizeof r->detail, "no frame in %g s", st->seconds);
        return false;
    }
    char *buf = NULL;
    size_t len = 0;
    FILE *mem = open_memstream(&buf, &len);
    bool ok = scen_check_end(&chk, mem, "; ");
    if (mem) fclose(mem);
    if (buf) { /* one line per step: the lines' ends go, each starts with "; " */
        char *o = buf;
        for (const char *p = buf; *p; p++)
            if (*p != '\n') *o++ = *p;
        *o = '\0';
    }
    double fps;
    scen_check_fps_ok(&chk, &fps);
    snprintf(r->detail, sizeof r->detail, "%lu frames, %.1f frames/s, longest gap %.1f ms%s%.700s", chk.frames, fps,
             (double)chk.max_gap_ns / 1e6, chk.groom_unchecked ? ", some of a superseded groom (not checked)" : "",
             buf ? buf : "");
    free(buf);
    return ok;
}

/* Prints s as a JSON string. */
static void put_json_string(FILE *fp, const char *s)
{
    fputc('"', fp);
    for (; *s; s++) {
        unsigned char ch = (unsigned char)*s;
        if (ch == '"' || ch == '\\') fprintf(fp, "\\%c", ch);
        else if (ch < 0x20) fprintf(fp, "\\u%04x", ch);
        else fputc(ch, fp);
    }
    fputc('"', fp);
}

static void report(runner *r, size_t i, const scen_step *st, bool ok, double t)
{
    if (r->d->json) {
        fprintf(r->out, "{\"step\":%zu,\"kind\":\"%s\",\"ok\":%s,\"t\":%.3f,\"frames\":%lu,\"sim_time\":%.4f,\"detail\":", i,
                scen_kind_name(st->kind), ok ? "true" : "false", t, r->frames, r->have_frame ? r->last.sim.sim_time : -1.0);
        put_json_string(r->out, r->detail);
        fprintf(r->out, ",\"seen\":%s}\n", r->seen ? r->seen : "null");
    } else {
        fprintf(r->out, "%s step %zu %-14s %8.3f s  %s\n", ok ? "ok  " : "FAIL", i, scen_kind_name(st->kind), t, r->detail);
    }
    fflush(r->out);
}

static bool run_step(runner *r, const scen_step *st)
{
    r->detail[0] = '\0';
    set_seen(r, NULL);
    switch (st->kind) {
    case SCEN_SEND: return run_send(r, st);
    case SCEN_REPLY: return run_reply(r, st);
    case SCEN_EXPECT: return run_expect(r, st);
    case SCEN_CHECK: return run_check(r, st);
    default: return run_wait(r, st);
    }
}

static bool connect_hello(runner *r, const char *host, int port, const char *path)
{
    r->w = wsc_new();
    r->conn = r->w ? wsc_connect_host(r->w, host, port, path, PROTO_SUBPROTOCOL, on_frame, r) : NULL;
    if (!r->conn || !wsc_wait_open(r->w, r->conn, SCEN_CONNECT_MS)) {
        fprintf(stderr, "strandcastc: cannot connect to ws://%s:%d%s with subprotocol %s\n", host, port, path,
                PROTO_SUBPROTOCOL);
        return false;
    }
    const char *hello = wsc_next_of_type(r->w, r->conn, "hello", SCEN_CONNECT_MS);
    core_err err;
    r->host = host;
    r->port = port;
    if (!hello || scen_world_hello(&r->world, hello, strlen(hello), fetch_http, r, &err) != CORE_OK) {
        const char *why = hello ? err.msg : wsc_last_text(r->conn); /* a refusal the server sent */
        fprintf(stderr, "strandcastc: no usable hello from the server%s%.300s\n", *why ? ": " : "", why);
        return false;
    }
    r->have_world = true;
    size_t n;
    char *const *t = wsc_texts(r->conn, &n);
    while (r->next_text < n && t[r->next_text] != hello) r->next_text++;
    r->hello_at = r->next_text;
    r->next_text++; /* the hello itself is read */
    return true;
}

int scen_run(const scen_run_desc *d, const scen_script *s)
{
    runner r;
    memset(&r, 0, sizeof r);
    r.d = d;
    r.out = d->out ? d->out : stdout;
    codec_decoder_init(&r.dec);
    const char *host = d->host ? d->host : "127.0.0.1";
    int port = d->port ? d->port : NET_DEFAULT_PORT;
    int rc = 1;
    char path[PROTO_ROOM_PATH_MAX];
    if (!proto_room_path(d->room, path, sizeof path)) {
        fprintf(stderr, "strandcastc: \"%.64s\" is not a room name\n", d->room);
        goto done;
    }
    if (!connect_hello(&r, host, port, path)) goto done;
    r.t0 = core_now_ns();
    if (!d->json)
        fprintf(r.out, "strandcastc run: %s: ws://%s:%d%s, groom %u x %u, %d colliders, %zu steps\n",
                s->name[0] ? s->name : "script", host, port, path, r.world.strands, r.world.verts, r.world.ncolliders,
                s->nsteps);
    size_t failed = s->nsteps;
    for (size_t i = 0; i < s->nsteps && failed == s->nsteps; i++) {
        bool ok = run_step(&r, &s->steps[i]);
        report(&r, i, &s->steps[i], ok, elapsed_s(&r));
        if (!ok) failed = i;
    }
    rc = failed < s->nsteps;
    if (d->json) {
        char f[32] = "null";
        if (rc) snprintf(f, sizeof f, "%zu", failed);
        fprintf(r.out, "{\"summary\":true,\"ok\":%s,\"steps\":%zu,\"failed_step\":%s,\"frames\":%lu,\"seconds\":%.3f}\n",
                rc ? "false" : "true", s->nsteps, f, r.frames, elapsed_s(&r));
    } else if (rc)
        fprintf(r.out, "strandcastc run: %s: step %zu (%s) failed: %s\n", s->name[0] ? s->name : "script", failed,
                scen_kind_name(s->steps[failed].kind), r.detail);
    else
        fprintf(r.out, "strandcastc run: %s: all %zu steps held (%lu frames in %.2f s)\n", s->name[0] ? s->name : "script",
                s->nsteps, r.frames, elapsed_s(&r));
done:
    wsc_free(r.w);
    for (size_t i = r.qhead; i < r.qlen; i++) free(r.queue[i].data);
    free(r.queue);
    if (r.have_world) scen_world_free(&r.world);
    codec_decoder_free(&r.dec);
    free(r.xyz);
    free(r.msgs);
    free(r.seen);
    cJSON_Delete(r.frame_json);
    cJSON_Delete(r.metric_json);
    return rc;
}
