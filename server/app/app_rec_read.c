/* app: the record file format, reading: a whole file checked and decoded (proto/RECORD.md). */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "app_rec.h"

static void set_param(sim_params *p, const core_param_info *t, double v)
{
    char *f = (char *)p + t->offset;
    switch (t->type) {
    case CORE_PARAM_FLOAT: *(float *)f = (float)v; break;
    case CORE_PARAM_INT:
    case CORE_PARAM_ENUM: *(int32_t *)f = (int32_t)v; break;
    case CORE_PARAM_BOOL: *(bool *)f = v != 0.0; break;
    }
}

/* A checked reader of one record's payload. */
typedef struct rd {
    const uint8_t *p;
    size_t len, off, base; /* base: the payload's offset in the file */
    uint32_t index;
    core_err *err;
    core_status st;
} rd;

static core_status bad(rd *r, const char *field, const char *fmt, ...)
{
    if (r->st != CORE_OK) return r->st;
    char why[CORE_ERR_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why, sizeof why, fmt, ap);
    va_end(ap);
    r->st = core_fail(r->err, CORE_EFORMAT, "record %u at byte %zu: field %s: %s", r->index, r->base + r->off, field, why);
    return r->st;
}

static const uint8_t *take(rd *r, size_t n, const char *field)
{
    if (r->st != CORE_OK) return NULL;
    if (r->len - r->off < n) {
        bad(r, field, "the record ends %zu bytes early", n - (r->len - r->off));
        return NULL;
    }
    const uint8_t *p = r->p + r->off;
    r->off += n;
    return p;
}

static uint32_t le32(const uint8_t *p) { return p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }

static uint8_t get_u8(rd *r, const char *field)
{
    const uint8_t *p = take(r, 1, field);
    return p ? p[0] : 0;
}

static uint32_t get_u32(rd *r, const char *field)
{
    const uint8_t *p = take(r, 4, field);
    return p ? le32(p) : 0;
}

static uint64_t get_u64(rd *r, const char *field)
{
    const uint8_t *p = take(r, 8, field);
    return p ? le32(p) | (uint64_t)le32(p + 4) << 32 : 0;
}

static float get_f32(rd *r, const char *field)
{
    uint32_t u = get_u32(r, field);
    float f;
    memcpy(&f, &u, 4);
    if (r->st == CORE_OK && !isfinite(f)) bad(r, field, "not finite");
    return f;
}

static double get_f64(rd *r, const char *field)
{
    uint64_t u = get_u64(r, field);
    double f;
    memcpy(&f, &u, 8);
    if (r->st == CORE_OK && !isfinite(f)) bad(r, field, "not finite");
    return f;
}

/* A string of at most cap - 1 bytes into out (NUL-terminated). */
static void get_str(rd *r, char *out, size_t cap, const char *field)
{
    out[0] = '\0';
    const uint8_t *p = take(r, 2, field);
    if (!p) return;
    size_t n = p[0] | (size_t)p[1] << 8;
    if (n >= cap) {
        bad(r, field, "%zu bytes, at most %zu", n, cap - 1);
        return;
    }
    if (!(p = take(r, n, field))) return;
    memcpy(out, p, n);
    out[n] = '\0';
    if (strlen(out) != n) bad(r, field, "holds a NUL byte");
}

static size_t find_name(const char *const *names, size_t n, const char *s)
{
    size_t i = 0;
    while (i < n && strcmp(names[i], s) != 0) i++;
    return i;
}

static size_t find_param(const proto_parser *p, const char *s)
{
    size_t i = 0;
    while (i < p->nparams && strcmp(p->params[i].name, s) != 0) i++;
    return i;
}

/* The index of a parameter named name whose value v is in its range, or p->nparams (refused). */
static size_t check_param(rd *r, const proto_parser *p, const char *field, const char *name, double v)
{
    size_t k = find_param(p, name);
    if (r->st != CORE_OK) return p->nparams;
    if (k == p->nparams) {
        bad(r, field, "no parameter named \"%s\" in this build", name);
    } else if (v < p->params[k].min || v > p->params[k].max) {
        bad(r, field, "%s = %.17g is outside [%g, %g]", name, v, p->params[k].min, p->params[k].max);
        k = p->nparams;
    }
    return k;
}

static void read_start(rd *r, const proto_parser *p, app_rec_start *s)
{
    memset(s, 0, sizeof *s);
    sim_params_default(&s->params);
    get_str(r, s->groom, sizeof s->groom, "groom");
    get_str(r, s->collider, sizeof s->collider, "collider");
    s->strands = get_u32(r, "strands");
    s->verts = get_u32(r, "verts");
    s->seed = get_u64(r, "seed");
    s->backend = get_u32(r, "backend");
    if (r->st == CORE_OK && s->backend != SIM_BACKEND_CPU && s->backend != SIM_BACKEND_VULKAN)
        bad(r, "backend", "%u is no backend (1 cpu, 2 vulkan)", s->backend);
    s->threads = (int32_t)get_u32(r, "threads");
    uint32_t n = get_u32(r, "params");
    for (uint32_t i = 0; i < n && r->st == CORE_OK; i++) {
        char name[64];
        get_str(r, name, sizeof name, "params");
        double v = get_f64(r, "params");
        size_t k = check_param(r, p, "params", name, v);
        if (r->st == CORE_OK) set_param(&s->params, &p->params[k], v);
    }
    core_err why;
    if (r->st == CORE_OK && sim_params_validate(&s->params, &why) != CORE_OK) bad(r, "params", "%s", why.msg);
}

static void read_input(rd *r, const proto_parser *p, proto_msg *m)
{
    memset(m, 0, sizeof *m);
    char name[64];
    get_str(r, name, sizeof name, "type");
    static const proto_type kinds[] = { PROTO_SET_PARAMS, PROTO_MOTION, PROTO_ANIMATE, PROTO_RESET,
                                        PROTO_PAUSE,      PROTO_RESUME, PROTO_STEP,    PROTO_SET_GROOM };
    size_t k = 0;
    while (k < sizeof kinds / sizeof kinds[0] && strcmp(proto_type_name(kinds[k]), name) != 0) k++;
    if (r->st != CORE_OK) return;
    if (k == sizeof kinds / sizeof kinds[0]) {
        bad(r, "type", "\"%s\" is no recorded input type", name);
        return;
    }
    m->type = kinds[k];
    switch (m->type) {
    case PROTO_SET_PARAMS:
        m->u.set_params.count = get_u32(r, "values");
        if (r->st == CORE_OK && (m->u.set_params.count == 0 || m->u.set_params.count > p->nparams))
            bad(r, "values", "%u values (1..%zu)", m->u.set_params.count, p->nparams);
        for (uint32_t i = 0; i < m->u.set_params.count && r->st == CORE_OK; i++) {
            get_str(r, name, sizeof name, "values");
            m->u.set_params.v[i].value = get_f64(r, "values");
            m->u.set_params.v[i].index = (uint32_t)check_param(r, p, "values", name, m->u.set_params.v[i].value);
        }
        break;
    case PROTO_MOTION: {
        float *v = &m->u.motion.position.x, *q = &m->u.motion.orientation.x;
        for (int i = 0; i < 3; i++) {
            v[i] = get_f32(r, "position");
            if (r->st == CORE_OK && fabsf(v[i]) > PROTO_MAX_POSITION)
                bad(r, "position", "%g is outside [-%g, %g]", v[i], PROTO_MAX_POSITION, PROTO_MAX_POSITION);
        }
        for (int i = 0; i < 4; i++) q[i] = get_f32(r, "orientation");
        if (r->st == CORE_OK && fabsf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] - 1.0f) > 1e-3f)
            bad(r, "orientation", "not a unit quaternion");
        break;
    }
    case PROTO_ANIMATE:
        get_str(r, name, sizeof name, "preset");
        m->u.animate.speed = get_f64(r, "speed");
        if (r->st == CORE_OK && (m->u.animate.speed < 0.0 || m->u.animate.speed > PROTO_MAX_SPEED))
            bad(r, "speed", "%g is outside [0, %g]", m->u.animate.speed, PROTO_MAX_SPEED);
        m->u.animate.preset = (uint32_t)find_name(p->presets, p->npresets, name);
        if (r->st == CORE_OK && m->u.animate.preset == p->npresets) bad(r, "preset", "no preset named \"%s\"", name);
        break;
    case PROTO_STEP:
        m->u.step.count = (int32_t)get_u32(r, "count");
        if (r->st == CORE_OK && (m->u.step.count < 1 || m->u.step.count > PROTO_MAX_STEP))
            bad(r, "count", "%d (1..%d)", m->u.step.count, PROTO_MAX_STEP);
        break;
    case PROTO_SET_GROOM:
        m->u.set_groom.is_file = get_u8(r, "file") != 0;
        get_str(r, m->u.set_groom.file, sizeof m->u.set_groom.file, m->u.set_groom.is_file ? "file" : "style");
        if (!m->u.set_groom.is_file && r->st == CORE_OK) {
            m->u.set_groom.style = (uint32_t)find_name(p->styles, p->nstyles, m->u.set_groom.file);
            if (m->u.set_groom.style == p->nstyles) bad(r, "style", "no style named \"%s\"", m->u.set_groom.file);
            m->u.set_groom.file[0] = '\0';
        }
        m->u.set_groom.strands = get_u32(r, "strands");
        m->u.set_groom.verts = get_u32(r, "verts");
        m->u.set_groom.has_seed = get_u8(r, "seed") != 0;
        m->u.set_groom.seed = get_u64(r, "seed");
        m->u.set_groom.collider_mode = (proto_collider_mode)get_u8(r, "collider");
        if (r->st == CORE_OK && m->u.set_groom.collider_mode > PROTO_COLLIDER_FILE)
            bad(r, "collider", "mode %u (0 keep, 1 none, 2 file)", (unsigned)m->u.set_groom.collider_mode);
        get_str(r, m->u.set_groom.collider, sizeof m->u.set_groom.collider, "collider");
        break;
    default: break;
    }
}

/* One framed record at data + *off into *out (the start record into *s); advances *off. */
static core_status read_record(const uint8_t *data, size_t len, size_t *off, uint32_t index, const proto_parser *p,
                               app_rec_start *s, app_rec *out, core_err *err)
{
    rd r = { data + *off, len - *off, 0, *off, index, err, CORE_OK };
    memset(out, 0, sizeof *out);
    out->index = index;
    out->offset = *off;
    if (r.len < APP_REC_FRAME + 4)
        return core_fail(err, CORE_EFORMAT, "record %u at byte %zu: field length: truncated: %zu bytes left, a record takes at least %d",
                         index, *off, r.len, APP_REC_FRAME + 4);
    uint32_t payload = le32(r.p);
    if (payload > APP_REC_MAX_PAYLOAD)
        return core_fail(err, CORE_EFORMAT, "record %u at byte %zu: field length: %u bytes, at most %u (corrupt)", index, *off,
                         payload, APP_REC_MAX_PAYLOAD);
    size_t total = APP_REC_FRAME + (size_t)payload + 4;
    if (total > r.len)
        return core_fail(err, CORE_EFORMAT, "record %u at byte %zu: field length: truncated: the record takes %zu bytes, %zu are left",
                         index, *off, total, r.len);
    uint32_t want = le32(r.p + total - 4), got = (uint32_t)crc32(0, r.p + 4, (uInt)(total - 8));
    if (want != got)
        return core_fail(err, CORE_EFORMAT, "record %u at byte %zu: field crc32: the bytes do not match their checksum (corrupt)",
                         index, *off);
    out->kind = (app_rec_kind)r.p[4];
    out->step = le32(r.p + 5) | (uint64_t)le32(r.p + 9) << 32;
    r.len = APP_REC_FRAME + payload;
    r.off = APP_REC_FRAME;
    if (index == 0 && out->kind != APP_REC_START) return bad(&r, "kind", "the first record must be the start (1), not %d", out->kind);
    if (index > 0 && out->kind == APP_REC_START) return bad(&r, "kind", "a second start record");
    switch (out->kind) {
    case APP_REC_START: read_start(&r, p, s); break;
    case APP_REC_INPUT: read_input(&r, p, &out->msg); break;
    case APP_REC_DIGEST: out->digest = get_u64(&r, "digest"); break;
    case APP_REC_END: break;
    default: return bad(&r, "kind", "%d is no record kind (1..4)", out->kind);
    }
    if (r.st == CORE_OK && r.off != r.len) bad(&r, "length", "%zu bytes past the record's fields", r.len - r.off);
    if (r.st != CORE_OK) return r.st;
    *off += total;
    return CORE_OK;
}

core_status app_rec_read(const uint8_t *data, size_t len, const proto_parser *p, app_rec_start *s, app_rec **out,
                         size_t *n, core_err *err)
{
    *out = NULL;
    *n = 0;
    if (len < APP_REC_FILE_HEADER || memcmp(data, APP_REC_MAGIC, APP_REC_MAGIC_LEN) != 0)
        return core_fail(err, CORE_EFORMAT, "byte 0: field magic: not a strandcast recording (no \"SCREC\" header)");
    uint32_t version = le32(data + APP_REC_MAGIC_LEN);
    if (version != APP_REC_VERSION)
        return core_fail(err, CORE_EFORMAT, "byte %d: field version: format version %u; this strandcastd reads version %u",
                         APP_REC_MAGIC_LEN, version, APP_REC_VERSION);
    size_t cap = 0, off = APP_REC_FILE_HEADER;
    app_rec *v = NULL;
    core_status st = CORE_OK;
    uint64_t last = 0;
    bool ended = false;
    for (uint32_t index = 0; st == CORE_OK && off < len; index++) {
        if (ended) {
            st = core_fail(err, CORE_EFORMAT, "record %u at byte %zu: field kind: records after the end record (corrupt)", index, off);
            break;
        }
        if (*n == cap) {
            cap = cap ? cap * 2 : 256;
            app_rec *g = realloc(v, cap * sizeof *v);
            if (!g) {
                st = core_fail(err, CORE_ENOMEM, "out of memory for %zu records", cap);
                break;
            }
            v = g;
        }
        app_rec *r = &v[*n];
        if ((st = read_record(data, len, &off, index, p, s, r, err)) != CORE_OK) break;
        if (r->step < last) {
            st = core_fail(err, CORE_EFORMAT, "record %u at byte %zu: field step: %llu is before the previous record's %llu",
                           index, r->offset, (unsigned long long)r->step, (unsigned long long)last);
            break;
        }
        last = r->step;
        ended = r->kind == APP_REC_END;
        if (r->kind != APP_REC_START) (*n)++;
    }
    if (st == CORE_OK && !ended)
        st = core_fail(err, CORE_EFORMAT, "byte %zu: field end: truncated: the recording has no end record (the daemon that wrote it "
                       "did not stop cleanly, or the file was cut)", len);
    if (st != CORE_OK) {
        free(v);
        *n = 0;
        return st;
    }
    *out = v;
    return CORE_OK;
}
