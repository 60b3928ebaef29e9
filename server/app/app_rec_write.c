/* app: the record file format, writing: records encoded into a growing buffer (proto/RECORD.md). */
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "app_rec.h"

void app_rec_buf_free(app_rec_buf *b)
{
    free(b->p);
    memset(b, 0, sizeof *b);
}

static void put(app_rec_buf *b, const void *src, size_t n)
{
    if (b->oom) return;
    if (b->len + n > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->len + n) cap *= 2;
        uint8_t *p = realloc(b->p, cap);
        if (!p) {
            b->oom = true;
            return;
        }
        b->p = p;
        b->cap = cap;
    }
    memcpy(b->p + b->len, src, n);
    b->len += n;
}

static void put_u8(app_rec_buf *b, uint8_t v) { put(b, &v, 1); }

static void put_u32(app_rec_buf *b, uint32_t v)
{
    uint8_t x[4] = { (uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), (uint8_t)(v >> 24) };
    put(b, x, 4);
}

static void put_u64(app_rec_buf *b, uint64_t v)
{
    put_u32(b, (uint32_t)v);
    put_u32(b, (uint32_t)(v >> 32));
}

static void put_f32(app_rec_buf *b, float v)
{
    uint32_t u;
    memcpy(&u, &v, 4);
    put_u32(b, u);
}

static void put_f64(app_rec_buf *b, double v)
{
    uint64_t u;
    memcpy(&u, &v, 8);
    put_u64(b, u);
}

static void put_str(app_rec_buf *b, const char *s)
{
    size_t n = strlen(s);
    if (n > 0xffff) n = 0xffff;
    uint8_t x[2] = { (uint8_t)n, (uint8_t)(n >> 8) };
    put(b, x, 2);
    put(b, s, n);
}

/* Opens a record: returns where it starts (its length is patched by end_record). */
static size_t begin_record(app_rec_buf *b, app_rec_kind kind, uint64_t step)
{
    size_t at = b->len;
    put_u32(b, 0);
    put_u8(b, (uint8_t)kind);
    put_u64(b, step);
    return at;
}

static void end_record(app_rec_buf *b, size_t at)
{
    if (b->oom) return;
    uint32_t payload = (uint32_t)(b->len - at - APP_REC_FRAME);
    uint8_t *p = b->p + at;
    p[0] = (uint8_t)payload, p[1] = (uint8_t)(payload >> 8), p[2] = (uint8_t)(payload >> 16), p[3] = (uint8_t)(payload >> 24);
    uint32_t crc = (uint32_t)crc32(0, p + 4, (uInt)(b->len - at - 4));
    put_u32(b, crc);
}

void app_rec_put_file_header(app_rec_buf *b)
{
    put(b, APP_REC_MAGIC, APP_REC_MAGIC_LEN);
    put_u32(b, APP_REC_VERSION);
}

static double param_value(const sim_params *p, const core_param_info *t)
{
    const char *f = (const char *)p + t->offset;
    switch (t->type) {
    case CORE_PARAM_FLOAT: return *(const float *)f;
    case CORE_PARAM_INT:
    case CORE_PARAM_ENUM: return *(const int32_t *)f;
    case CORE_PARAM_BOOL: return *(const bool *)f ? 1.0 : 0.0;
    }
    return 0.0;
}

void app_rec_put_start(app_rec_buf *b, const app_rec_start *s, const core_param_info *table, size_t n)
{
    size_t at = begin_record(b, APP_REC_START, 0);
    put_str(b, s->groom);
    put_str(b, s->collider);
    put_u32(b, s->strands);
    put_u32(b, s->verts);
    put_u64(b, s->seed);
    put_u32(b, s->backend);
    put_u32(b, (uint32_t)s->threads);
    put_u32(b, (uint32_t)n);
    for (size_t i = 0; i < n; i++) {
        put_str(b, table[i].name);
        put_f64(b, param_value(&s->params, &table[i]));
    }
    end_record(b, at);
}

void app_rec_put_input(app_rec_buf *b, uint64_t step, const proto_msg *m, const proto_parser *p)
{
    size_t at = begin_record(b, APP_REC_INPUT, step);
    put_str(b, proto_type_name(m->type));
    switch (m->type) {
    case PROTO_SET_PARAMS:
        put_u32(b, m->u.set_params.count);
        for (uint32_t i = 0; i < m->u.set_params.count; i++) {
            put_str(b, p->params[m->u.set_params.v[i].index].name);
            put_f64(b, m->u.set_params.v[i].value);
        }
        break;
    case PROTO_MOTION: {
        const float *v = &m->u.motion.position.x, *q = &m->u.motion.orientation.x;
        for (int i = 0; i < 3; i++) put_f32(b, v[i]);
        for (int i = 0; i < 4; i++) put_f32(b, q[i]);
        break;
    }
    case PROTO_ANIMATE:
        put_str(b, p->presets[m->u.animate.preset]);
        put_f64(b, m->u.animate.speed);
        break;
    case PROTO_STEP: put_u32(b, (uint32_t)m->u.step.count); break;
    case PROTO_SET_GROOM:
        put_u8(b, m->u.set_groom.is_file);
        put_str(b, m->u.set_groom.is_file ? m->u.set_groom.file : p->styles[m->u.set_groom.style]);
        put_u32(b, m->u.set_groom.strands);
        put_u32(b, m->u.set_groom.verts);
        put_u8(b, m->u.set_groom.has_seed);
        put_u64(b, m->u.set_groom.seed);
        put_u8(b, (uint8_t)m->u.set_groom.collider_mode);
        put_str(b, m->u.set_groom.collider);
        break;
    default: break; /* reset, pause, resume: the type says it all */
    }
    end_record(b, at);
}

void app_rec_put_digest(app_rec_buf *b, uint64_t step, uint64_t digest)
{
    size_t at = begin_record(b, APP_REC_DIGEST, step);
    put_u64(b, digest);
    end_record(b, at);
}

void app_rec_put_end(app_rec_buf *b, uint64_t step) { end_record(b, begin_record(b, APP_REC_END, step)); }

uint64_t app_rec_digest(const float *xyz, size_t n)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < n; i++) {
        uint32_t u;
        memcpy(&u, &xyz[i], 4);
        h = (h ^ u) * 0x100000001b3ull;
        h ^= h >> 29;
    }
    return h;
}
