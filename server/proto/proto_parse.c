/* proto: parses and validates client text messages into typed proto_msg structs. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "proto.h"
#include "proto_json.h"

#define MAX_FIELDS 16 /* top-level fields any client message may have */

static const char *const type_names[] = {
    [PROTO_GET_PARAMS] = "get_params", [PROTO_SET_PARAMS] = "set_params", [PROTO_MOTION] = "motion",
    [PROTO_ANIMATE] = "animate",       [PROTO_RESET] = "reset",           [PROTO_PAUSE] = "pause",
    [PROTO_RESUME] = "resume",         [PROTO_STEP] = "step",             [PROTO_SET_GROOM] = "set_groom",
    [PROTO_SUBSCRIBE] = "subscribe",   [PROTO_KEYFRAME] = "keyframe",
    [PROTO_AUTH] = "auth",
};
#define NTYPES (sizeof type_names / sizeof type_names[0])

static const char *const code_names[] = {
    [PROTO_ERR_NONE] = "none",
    [PROTO_ERR_BAD_JSON] = "bad_json",
    [PROTO_ERR_UNKNOWN_TYPE] = "unknown_type",
    [PROTO_ERR_BAD_FIELD] = "bad_field",
    [PROTO_ERR_OUT_OF_RANGE] = "out_of_range",
    [PROTO_ERR_NOT_FINITE] = "not_finite",
    [PROTO_ERR_UNKNOWN_PARAM] = "unknown_param",
    [PROTO_ERR_TOO_LARGE] = "too_large",
    [PROTO_ERR_NOT_FOUND] = "not_found",
    [PROTO_ERR_BAD_STATE] = "bad_state",
    [PROTO_ERR_RATE_LIMITED] = "rate_limited",
    [PROTO_ERR_FORBIDDEN] = "forbidden",
    [PROTO_ERR_BUSY] = "busy",
    [PROTO_ERR_FAILED] = "failed",
    [PROTO_ERR_BAD_ROOM] = "bad_room",
    [PROTO_ERR_UNKNOWN_ROOM] = "unknown_room",
    [PROTO_ERR_ROOM_UNAVAILABLE] = "room_unavailable",
};

const char *proto_type_name(proto_type type)
{
    return (size_t)type < NTYPES && type_names[type] ? type_names[type] : "unknown";
}

const char *proto_code_name(proto_code code)
{
    return (size_t)code < sizeof code_names / sizeof code_names[0] ? code_names[code] : "unknown";
}

core_status proto_fail(proto_error *e, proto_code code, const char *field, const char *fmt, ...)
{
    e->code = code;
    snprintf(e->field, sizeof e->field, "%s", field ? field : "");
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(e->message, sizeof e->message, fmt, ap);
    va_end(ap);
    return CORE_EINVAL;
}

/* Fields each message type accepts besides "type" and "id". */
static const char *const *allowed_fields(proto_type t)
{
    static const char *const none[] = { NULL };
    static const char *const set_params[] = { "values", NULL };
    static const char *const motion[] = { "t", "position", "orientation", NULL };
    static const char *const animate[] = { "preset", "speed", NULL };
    static const char *const step[] = { "count", NULL };
    static const char *const set_groom[] = { "style", "file", "strands", "verts", "seed", "collider", NULL };
    static const char *const subscribe[] = { "stride", "max_error", "max_rate", "source", NULL };
    static const char *const auth[] = { "token", NULL };
    switch (t) {
    case PROTO_SET_PARAMS: return set_params;
    case PROTO_MOTION: return motion;
    case PROTO_ANIMATE: return animate;
    case PROTO_STEP: return step;
    case PROTO_SET_GROOM: return set_groom;
    case PROTO_SUBSCRIBE: return subscribe;
    case PROTO_AUTH: return auth;
    default: return none;
    }
}

/* Every key of obj must be "type", "id" or in allowed, and appear once. */
static core_status check_fields(const cJSON *obj, const char *const *allowed, proto_error *e)
{
    int n = 0;
    for (const cJSON *c = obj->child; c; c = c->next) {
        if (++n > MAX_FIELDS) return proto_fail(e, PROTO_ERR_TOO_LARGE, "", "message has more than %d fields", MAX_FIELDS);
        bool ok = strcmp(c->string, "type") == 0 || strcmp(c->string, "id") == 0;
        for (const char *const *a = allowed; !ok && *a; a++) ok = strcmp(c->string, *a) == 0;
        if (!ok) return proto_fail(e, PROTO_ERR_BAD_FIELD, c->string, "unknown field \"%.64s\"", c->string);
        for (const cJSON *d = obj->child; d != c; d = d->next)
            if (strcmp(d->string, c->string) == 0)
                return proto_fail(e, PROTO_ERR_BAD_FIELD, c->string, "field \"%.64s\" appears twice", c->string);
    }
    return CORE_OK;
}

/* A finite number; 1 = read, 0 = absent and optional. */
static int get_number(const cJSON *obj, const char *name, bool required, double *out, proto_error *e, core_status *st)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, name);
    *st = CORE_OK;
    if (!v) {
        if (required) *st = proto_fail(e, PROTO_ERR_BAD_FIELD, name, "missing field \"%s\"", name);
        return 0;
    }
    if (!cJSON_IsNumber(v)) {
        *st = proto_fail(e, PROTO_ERR_BAD_FIELD, name, "\"%s\" must be a number", name);
        return 0;
    }
    if (!isfinite(v->valuedouble)) {
        *st = proto_fail(e, PROTO_ERR_NOT_FINITE, name, "\"%s\" is not a finite number", name);
        return 0;
    }
    *out = v->valuedouble;
    return 1;
}

static core_status check_range(const char *field, double v, double lo, double hi, proto_error *e)
{
    if (v < lo || v > hi) return proto_fail(e, PROTO_ERR_OUT_OF_RANGE, field, "%s = %g is outside [%g, %g]", field, v, lo, hi);
    return CORE_OK;
}

static core_status check_int(const char *field, double v, proto_error *e)
{
    if (v != floor(v)) return proto_fail(e, PROTO_ERR_BAD_FIELD, field, "%s = %g must be an integer", field, v);
    return CORE_OK;
}

/* Optional number in [lo, hi] (integral when is_int). Returns 1 when present. */
static int get_ranged(const cJSON *obj, const char *name, bool required, bool is_int, double lo, double hi,
                      double *out, proto_error *e, core_status *st)
{
    if (!get_number(obj, name, required, out, e, st)) return 0;
    if (is_int && (*st = check_int(name, *out, e)) != CORE_OK) return 0;
    if ((*st = check_range(name, *out, lo, hi, e)) != CORE_OK) return 0;
    return 1;
}

/* A string of at most maxlen bytes; 1 = read, 0 = absent or error (*st says which). */
static int get_string(const cJSON *obj, const char *name, bool required, size_t maxlen, const char **out,
                      proto_error *e, core_status *st)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, name);
    *st = CORE_OK;
    if (!v) {
        if (required) *st = proto_fail(e, PROTO_ERR_BAD_FIELD, name, "missing field \"%s\"", name);
        return 0;
    }
    if (!cJSON_IsString(v)) {
        *st = proto_fail(e, PROTO_ERR_BAD_FIELD, name, "\"%s\" must be a string", name);
        return 0;
    }
    size_t n = strlen(v->valuestring);
    if (n > maxlen) {
        *st = proto_fail(e, PROTO_ERR_TOO_LARGE, name, "\"%s\" is %zu bytes; the limit is %zu", name, n, maxlen);
        return 0;
    }
    *out = v->valuestring;
    return 1;
}

/* Index of s in names, or a PROTO_ERR_OUT_OF_RANGE listing them. */
static core_status lookup_name(const char *field, const char *s, const char *const *names, size_t n,
                               uint32_t *out, proto_error *e)
{
    for (size_t i = 0; i < n; i++)
        if (strcmp(s, names[i]) == 0) {
            *out = (uint32_t)i;
            return CORE_OK;
        }
    char list[160] = "";
    size_t used = 0;
    for (size_t i = 0; i < n && used < sizeof list; i++) {
        int w = snprintf(list + used, sizeof list - used, "%s%s", i ? ", " : "", names[i]);
        if (w < 0) break;
        used += (size_t)w;
    }
    return proto_fail(e, PROTO_ERR_OUT_OF_RANGE, field, "unknown %s \"%.48s\"; one of: %s", field, s, list);
}

/* An array of exactly n finite numbers. */
static core_status get_vector(const cJSON *obj, const char *name, int n, double *out, proto_error *e)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, name);
    if (!v) return proto_fail(e, PROTO_ERR_BAD_FIELD, name, "missing field \"%s\"", name);
    if (!cJSON_IsArray(v)) return proto_fail(e, PROTO_ERR_BAD_FIELD, name, "\"%s\" must be an array of %d numbers", name, n);
    int i = 0;
    for (const cJSON *c = v->child; c; c = c->next, i++) {
        char field[32];
        snprintf(field, sizeof field, "%s[%d]", name, i);
        if (i >= n) return proto_fail(e, PROTO_ERR_BAD_FIELD, name, "\"%s\" must have exactly %d elements", name, n);
        if (!cJSON_IsNumber(c)) return proto_fail(e, PROTO_ERR_BAD_FIELD, field, "%s must be a number", field);
        if (!isfinite(c->valuedouble)) return proto_fail(e, PROTO_ERR_NOT_FINITE, field, "%s is not a finite number", field);
        out[i] = c->valuedouble;
    }
    if (i != n) return proto_fail(e, PROTO_ERR_BAD_FIELD, name, "\"%s\" must have exactly %d elements", name, n);
    return CORE_OK;
}

static core_status parse_id(const cJSON *root, proto_id *id, proto_error *e)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(root, "id");
    if (!v) return CORE_OK;
    if (cJSON_IsNumber(v)) {
        if (!isfinite(v->valuedouble)) return proto_fail(e, PROTO_ERR_NOT_FINITE, "id", "\"id\" is not a finite number");
        id->kind = PROTO_ID_NUMBER;
        id->num = v->valuedouble;
        return CORE_OK;
    }
    if (cJSON_IsString(v)) {
        size_t n = strlen(v->valuestring);
        if (n > PROTO_MAX_ID)
            return proto_fail(e, PROTO_ERR_TOO_LARGE, "id", "\"id\" is %zu bytes; the limit is %d", n, PROTO_MAX_ID);
        id->kind = PROTO_ID_STRING;
        memcpy(id->str, v->valuestring, n + 1);
        return CORE_OK;
    }
    return proto_fail(e, PROTO_ERR_BAD_FIELD, "id", "\"id\" must be a number or a string");
}

static core_status parse_set_params(const proto_parser *p, const cJSON *root, proto_msg *m, proto_error *e)
{
    const cJSON *values = cJSON_GetObjectItemCaseSensitive(root, "values");
    if (!values) return proto_fail(e, PROTO_ERR_BAD_FIELD, "values", "missing field \"values\"");
    if (!cJSON_IsObject(values)) return proto_fail(e, PROTO_ERR_BAD_FIELD, "values", "\"values\" must be an object");
    if (!values->child) return proto_fail(e, PROTO_ERR_BAD_FIELD, "values", "\"values\" names no parameter");
    uint32_t n = 0;
    for (const cJSON *c = values->child; c; c = c->next) {
        char field[96];
        snprintf(field, sizeof field, "values.%.80s", c->string);
        if (n >= p->nparams || n >= PROTO_MAX_PARAMS)
            return proto_fail(e, PROTO_ERR_TOO_LARGE, "values", "\"values\" has more entries than the %zu parameters", p->nparams);
        uint32_t idx = 0;
        while (idx < p->nparams && strcmp(p->params[idx].name, c->string) != 0) idx++;
        if (idx == p->nparams) return proto_fail(e, PROTO_ERR_UNKNOWN_PARAM, field, "unknown parameter \"%.64s\"", c->string);
        for (uint32_t k = 0; k < n; k++)
            if (m->u.set_params.v[k].index == idx)
                return proto_fail(e, PROTO_ERR_BAD_FIELD, field, "parameter \"%s\" appears twice", p->params[idx].name);
        const core_param_info *t = &p->params[idx];
        double v;
        if (t->type == CORE_PARAM_BOOL) {
            if (!cJSON_IsBool(c)) return proto_fail(e, PROTO_ERR_BAD_FIELD, field, "%s must be true or false", field);
            v = cJSON_IsTrue(c) ? 1.0 : 0.0;
        } else if (t->type == CORE_PARAM_ENUM) {
            if (!cJSON_IsString(c)) return proto_fail(e, PROTO_ERR_BAD_FIELD, field, "%s must be a string: one of its choices", field);
            uint32_t k;
            if (lookup_name(field, c->valuestring, t->choices, (size_t)t->max + 1, &k, e) != CORE_OK) return CORE_EINVAL;
            v = k;
        } else {
            if (!cJSON_IsNumber(c)) return proto_fail(e, PROTO_ERR_BAD_FIELD, field, "%s must be a number", field);
            v = c->valuedouble;
            if (!isfinite(v)) return proto_fail(e, PROTO_ERR_NOT_FINITE, field, "%s is not a finite number", field);
            if (t->type == CORE_PARAM_INT && check_int(field, v, e) != CORE_OK) return CORE_EINVAL;
            if (check_range(field, v, t->min, t->max, e) != CORE_OK) return CORE_EINVAL;
        }
        m->u.set_params.v[n].index = idx;
        m->u.set_params.v[n].value = v;
        n++;
    }
    m->u.set_params.count = n;
    return CORE_OK;
}

static core_status parse_motion(const cJSON *root, proto_msg *m, proto_error *e)
{
    core_status st;
    m->u.motion.has_t = get_number(root, "t", false, &m->u.motion.t, e, &st);
    if (st != CORE_OK) return st;
    double pos[3], q[4];
    if ((st = get_vector(root, "position", 3, pos, e)) != CORE_OK) return st;
    if ((st = get_vector(root, "orientation", 4, q, e)) != CORE_OK) return st;
    for (int i = 0; i < 3; i++) {
        char field[32];
        snprintf(field, sizeof field, "position[%d]", i);
        if ((st = check_range(field, pos[i], -PROTO_MAX_POSITION, PROTO_MAX_POSITION, e)) != CORE_OK) return st;
    }
    double len = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(len > 1e-6) || !isfinite(len))
        return proto_fail(e, PROTO_ERR_OUT_OF_RANGE, "orientation", "orientation must be a quaternion [x,y,z,w] of nonzero length");
    m->u.motion.position = core_v3((float)pos[0], (float)pos[1], (float)pos[2]);
    core_quat r = { (float)(q[0] / len), (float)(q[1] / len), (float)(q[2] / len), (float)(q[3] / len) };
    m->u.motion.orientation = r;
    return CORE_OK;
}

static core_status parse_animate(const proto_parser *p, const cJSON *root, proto_msg *m, proto_error *e)
{
    core_status st;
    const char *preset;
    if (!get_string(root, "preset", true, 64, &preset, e, &st)) return st;
    if ((st = lookup_name("preset", preset, p->presets, p->npresets, &m->u.animate.preset, e)) != CORE_OK) return st;
    m->u.animate.speed = 1.0;
    get_ranged(root, "speed", false, false, 0.0, PROTO_MAX_SPEED, &m->u.animate.speed, e, &st);
    return st;
}

/* A file name (groom or collision mesh, in field) relative to the asset folder: no absolute
 * path, no "." or ".." parts. */
static core_status check_file_name(const char *field, const char *s, proto_error *e)
{
    if (!*s) return proto_fail(e, PROTO_ERR_BAD_FIELD, field, "\"%s\" is empty", field);
    const char *part = s;
    for (const char *c = s;; c++) {
        if (*c == '/' || *c == '\0') {
            size_t n = (size_t)(c - part);
            if (n == 0 || (n == 1 && part[0] == '.') || (n == 2 && part[0] == '.' && part[1] == '.'))
                return proto_fail(e, PROTO_ERR_BAD_FIELD, field,
                                  "\"%s\" must be a relative name inside the asset folder (no empty, \".\" or \"..\" parts)", field);
            if (*c == '\0') break;
            part = c + 1;
            continue;
        }
        bool ok = (*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') || *c == '.' ||
                  *c == '_' || *c == '-';
        if (!ok) return proto_fail(e, PROTO_ERR_BAD_FIELD, field, "\"%s\" may use only letters, digits, '.', '_', '-' and '/'", field);
    }
    return CORE_OK;
}

/* set_groom's optional "collider": absent (keep), null (none) or a file name. */
static core_status parse_collider(const cJSON *root, proto_msg *m, proto_error *e)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(root, "collider");
    if (!v) return CORE_OK;
    if (cJSON_IsNull(v)) {
        m->u.set_groom.collider_mode = PROTO_COLLIDER_NONE;
        return CORE_OK;
    }
    core_status st;
    const char *name = NULL;
    if (!cJSON_IsString(v)) return proto_fail(e, PROTO_ERR_BAD_FIELD, "collider", "\"collider\" must be a file name or null");
    get_string(root, "collider", true, PROTO_MAX_NAME, &name, e, &st);
    if (st != CORE_OK || (st = check_file_name("collider", name, e)) != CORE_OK) return st;
    m->u.set_groom.collider_mode = PROTO_COLLIDER_FILE;
    memcpy(m->u.set_groom.collider, name, strlen(name) + 1);
    return CORE_OK;
}

static core_status parse_set_groom(const proto_parser *p, const cJSON *root, proto_msg *m, proto_error *e)
{
    core_status st;
    const char *style = NULL, *file = NULL;
    int has_style = get_string(root, "style", false, 64, &style, e, &st);
    if (st != CORE_OK) return st;
    int has_file = get_string(root, "file", false, PROTO_MAX_NAME, &file, e, &st);
    if (st != CORE_OK) return st;
    if (has_style == has_file)
        return proto_fail(e, PROTO_ERR_BAD_FIELD, has_style ? "file" : "style", "set_groom needs exactly one of \"style\" and \"file\"");
    double v;
    if (has_style) {
        if ((st = lookup_name("style", style, p->styles, p->nstyles, &m->u.set_groom.style, e)) != CORE_OK) return st;
    } else {
        if ((st = check_file_name("file", file, e)) != CORE_OK) return st;
        m->u.set_groom.is_file = true;
        memcpy(m->u.set_groom.file, file, strlen(file) + 1);
    }
    if (get_ranged(root, "strands", false, true, 1, PROTO_MAX_STRANDS, &v, e, &st)) m->u.set_groom.strands = (uint32_t)v;
    if (st != CORE_OK) return st;
    if (get_ranged(root, "verts", false, true, 2, PROTO_MAX_VERTS, &v, e, &st)) m->u.set_groom.verts = (uint32_t)v;
    if (st != CORE_OK) return st;
    if (m->u.set_groom.is_file && m->u.set_groom.strands)
        return proto_fail(e, PROTO_ERR_BAD_FIELD, "strands", "a groom file sets its own strand count; leave out \"strands\"");
    if ((uint64_t)m->u.set_groom.strands * m->u.set_groom.verts > PROTO_MAX_VERTICES)
        return proto_fail(e, PROTO_ERR_TOO_LARGE, "strands", "%u strands x %u vertices is over the limit of %u vertices",
                          m->u.set_groom.strands, m->u.set_groom.verts, PROTO_MAX_VERTICES);
    if ((m->u.set_groom.has_seed = get_ranged(root, "seed", false, true, 0, 9007199254740991.0, &v, e, &st)))
        m->u.set_groom.seed = (uint64_t)v;
    if (st != CORE_OK) return st;
    return parse_collider(root, m, e);
}

static core_status parse_subscribe(const cJSON *root, proto_msg *m, proto_error *e)
{
    core_status st;
    double v;
    if ((m->u.subscribe.has_stride = get_ranged(root, "stride", false, true, 1, PROTO_MAX_STRIDE, &v, e, &st)))
        m->u.subscribe.stride = (int32_t)v;
    if (st != CORE_OK) return st;
    m->u.subscribe.has_max_error =
        get_ranged(root, "max_error", false, false, PROTO_MIN_ERROR, PROTO_MAX_ERROR, &m->u.subscribe.max_error, e, &st);
    if (st != CORE_OK) return st;
    m->u.subscribe.has_max_rate =
        get_ranged(root, "max_rate", false, false, 0.0, PROTO_MAX_RATE, &m->u.subscribe.max_rate, e, &st);
    if (st != CORE_OK) return st;
    static const char *const sources[] = { "strands", "hairmesh" };
    const char *source;
    if (!(m->u.subscribe.has_source = get_string(root, "source", false, 16, &source, e, &st))) return st;
    uint32_t k;
    if ((st = lookup_name("source", source, sources, 2, &k, e)) != CORE_OK) return st;
    m->u.subscribe.source = (proto_source)k;
    return CORE_OK;
}

const char *proto_source_name(proto_source s)
{
    return s == PROTO_SOURCE_HAIRMESH ? "hairmesh" : "strands";
}

static core_status parse_root(const proto_parser *p, const cJSON *root, proto_msg *m, proto_error *e)
{
    if (!cJSON_IsObject(root)) return proto_fail(e, PROTO_ERR_BAD_JSON, "", "a message must be a JSON object");
    core_status st = parse_id(root, &m->id, e);
    if (st != CORE_OK) return st;
    const cJSON *type = cJSON_GetObjectItemCaseSensitive(root, "type");
    if (!type) return proto_fail(e, PROTO_ERR_BAD_FIELD, "type", "missing field \"type\"");
    if (!cJSON_IsString(type)) return proto_fail(e, PROTO_ERR_BAD_FIELD, "type", "\"type\" must be a string");
    size_t t = 1;
    while (t < NTYPES && strcmp(type_names[t], type->valuestring) != 0) t++;
    if (t == NTYPES) return proto_fail(e, PROTO_ERR_UNKNOWN_TYPE, "type", "unknown message type \"%.64s\"", type->valuestring);
    m->type = (proto_type)t;
    if ((st = check_fields(root, allowed_fields(m->type), e)) != CORE_OK) return st;
    double v;
    switch (m->type) {
    case PROTO_SET_PARAMS: return parse_set_params(p, root, m, e);
    case PROTO_MOTION: return parse_motion(root, m, e);
    case PROTO_ANIMATE: return parse_animate(p, root, m, e);
    case PROTO_STEP:
        m->u.step.count = 1;
        if (get_ranged(root, "count", false, true, 1, PROTO_MAX_STEP, &v, e, &st)) m->u.step.count = (int32_t)v;
        return st;
    case PROTO_SET_GROOM: return parse_set_groom(p, root, m, e);
    case PROTO_SUBSCRIBE: return parse_subscribe(root, m, e);
    case PROTO_AUTH: {
        const char *token = NULL;
        get_string(root, "token", true, PROTO_MAX_TOKEN, &token, e, &st);
        if (st == CORE_OK) snprintf(m->u.auth.token, sizeof m->u.auth.token, "%s", token);
        return st;
    }
    default: return CORE_OK;
    }
}

core_status proto_parse(const proto_parser *p, const char *text, size_t len, proto_msg *out, proto_error *e)
{
    memset(out, 0, sizeof *out);
    memset(e, 0, sizeof *e);
    if (len > PROTO_MAX_MESSAGE)
        return proto_fail(e, PROTO_ERR_TOO_LARGE, "", "message is %zu bytes; the limit is %d", len, PROTO_MAX_MESSAGE);
    const char *end = NULL;
    cJSON *root = len ? cJSON_ParseWithLengthOpts(text, len, &end, 0) : NULL;
    if (!root) {
        size_t at = end && end >= text ? (size_t)(end - text) : 0;
        return proto_fail(e, PROTO_ERR_BAD_JSON, "", "not valid JSON (parse error at byte %zu)", at);
    }
    size_t at = (size_t)(end - text), bad;
    while (at < len && (text[at] == ' ' || text[at] == '\t' || text[at] == '\r' || text[at] == '\n')) at++;
    char member[PROTO_MAX_NAME + 1];
    const char *why;
    core_status st = at < len ? proto_fail(e, PROTO_ERR_BAD_JSON, "", "trailing data after the JSON value at byte %zu", at)
                     : !proto_json_strict(text, len, &bad, &why)
                         ? proto_fail(e, PROTO_ERR_BAD_JSON, "", "not valid JSON: %s at byte %zu", why, bad)
                         : parse_root(p, root, out, e);
    /* C strings end at a NUL: a name with \u0000 would be read cut short, so none is taken */
    if (st == CORE_OK && proto_json_nul_member(text, len, member, sizeof member))
        st = proto_fail(e, PROTO_ERR_BAD_FIELD, member, "strings may not contain NUL characters (\\u0000)");
    cJSON_Delete(root);
    return st;
}
