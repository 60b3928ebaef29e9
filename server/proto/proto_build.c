/* proto: builds the server -> client JSON messages (hello, params, state, errors, ...). */
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../core/utf8.h"
#include "proto.h"
#include "proto_json.h"

void proto_free(char *text) { cJSON_free(text); }

/* Prints and deletes obj; NULL when any allocation failed on the way (obj may be NULL). The
 * text is made valid UTF-8: strings echoed from clients or file names may have been cut inside
 * a character ("%.64s"), and JSON's structure is ASCII, so a '?' for such bytes is safe. */
static char *finish(cJSON *obj, bool ok)
{
    char *s = ok && obj ? cJSON_PrintUnformatted(obj) : NULL;
    cJSON_Delete(obj);
    if (s) core_utf8_repair(s, strlen(s));
    return s;
}

static bool add_id(cJSON *obj, const proto_id *id)
{
    if (!id || id->kind == PROTO_ID_NONE) return true;
    if (id->kind == PROTO_ID_NUMBER) return cJSON_AddNumberToObject(obj, "id", id->num) != NULL;
    return cJSON_AddStringToObject(obj, "id", id->str) != NULL;
}

static cJSON *new_message(const char *type, const proto_id *id)
{
    cJSON *obj = cJSON_CreateObject();
    if (!obj) return NULL;
    if (!cJSON_AddStringToObject(obj, "type", type) || !add_id(obj, id)) {
        cJSON_Delete(obj);
        return NULL;
    }
    return obj;
}

char *proto_build_error(const proto_id *id, const proto_error *e)
{
    cJSON *o = new_message("error", id);
    bool ok = o && cJSON_AddStringToObject(o, "code", proto_code_name(e->code)) &&
              cJSON_AddStringToObject(o, "field", e->field) && cJSON_AddStringToObject(o, "message", e->message);
    return finish(o, ok);
}

char *proto_build_ok(const proto_id *id, proto_type request, int64_t step)
{
    cJSON *o = new_message("ok", id);
    bool ok = o && cJSON_AddStringToObject(o, "request", proto_type_name(request)) &&
              (step < 0 || cJSON_AddNumberToObject(o, "step", (double)step));
    return finish(o, ok);
}

/* Adds name: value of one table entry read from the struct at values. */
static bool add_param_value(cJSON *obj, const core_param_info *t, const void *values)
{
    const char *field = (const char *)values + t->offset;
    switch (t->type) {
    case CORE_PARAM_FLOAT: return cJSON_AddNumberToObject(obj, t->name, proto_json_float(*(const float *)field)) != NULL;
    case CORE_PARAM_INT: return cJSON_AddNumberToObject(obj, t->name, *(const int32_t *)field) != NULL;
    case CORE_PARAM_BOOL: return cJSON_AddBoolToObject(obj, t->name, *(const bool *)field) != NULL;
    case CORE_PARAM_ENUM: {
        const int32_t k = *(const int32_t *)field; /* validated: a choice's index */
        return k >= 0 && k <= (int32_t)t->max && cJSON_AddStringToObject(obj, t->name, t->choices[k]) != NULL;
    }
    }
    return false;
}

static cJSON *param_values(const core_param_info *table, size_t n, const void *values)
{
    cJSON *v = cJSON_CreateObject();
    bool ok = v != NULL;
    for (size_t i = 0; ok && i < n; i++) ok = add_param_value(v, &table[i], values);
    if (!ok) {
        cJSON_Delete(v);
        return NULL;
    }
    return v;
}

/* Adds "changed": [the names of the entries with changed[i] set]. */
static bool add_changed(cJSON *obj, const core_param_info *table, size_t n, const bool *changed)
{
    cJSON *arr = cJSON_AddArrayToObject(obj, "changed");
    bool ok = arr != NULL;
    for (size_t i = 0; ok && i < n; i++)
        if (changed[i]) {
            cJSON *s = cJSON_CreateString(table[i].name);
            ok = s && cJSON_AddItemToArray(arr, s);
        }
    return ok;
}

char *proto_build_params(const proto_id *id, const core_param_info *table, size_t n, const void *values,
                         const bool *changed, int64_t by)
{
    cJSON *o = new_message("params", id);
    cJSON *v = o ? param_values(table, n, values) : NULL;
    bool ok = v && cJSON_AddItemToObject(o, "values", v);
    if (!ok) cJSON_Delete(v);
    ok = ok && (!changed || add_changed(o, table, n, changed));
    ok = ok && (by < 0 ? cJSON_AddNullToObject(o, "by") != NULL : cJSON_AddNumberToObject(o, "by", (double)by) != NULL);
    return finish(o, ok);
}

static const char *param_type_name(core_param_type t)
{
    switch (t) {
    case CORE_PARAM_FLOAT: return "float";
    case CORE_PARAM_INT: return "int";
    case CORE_PARAM_BOOL: return "bool";
    case CORE_PARAM_ENUM: return "enum";
    }
    return "unknown";
}

/* Adds key: [names...] to obj. */
static bool add_names(cJSON *obj, const char *key, const char *const *names, size_t n)
{
    cJSON *arr = cJSON_AddArrayToObject(obj, key);
    for (size_t i = 0; arr && i < n; i++) {
        cJSON *s = cJSON_CreateString(names[i]);
        if (!s || !cJSON_AddItemToArray(arr, s)) {
            cJSON_Delete(s);
            return false;
        }
    }
    return arr != NULL;
}

static cJSON *param_schema(const core_param_info *table, size_t n)
{
    cJSON *arr = cJSON_CreateArray();
    bool ok = arr != NULL;
    for (size_t i = 0; ok && i < n; i++) {
        const core_param_info *t = &table[i];
        cJSON *e = cJSON_CreateObject();
        ok = e && cJSON_AddItemToArray(arr, e);
        if (!ok) {
            cJSON_Delete(e);
            break;
        }
        bool is_bool = t->type == CORE_PARAM_BOOL, is_enum = t->type == CORE_PARAM_ENUM;
        ok = cJSON_AddStringToObject(e, "name", t->name) && cJSON_AddStringToObject(e, "type", param_type_name(t->type)) &&
             cJSON_AddNumberToObject(e, "min", t->min) && cJSON_AddNumberToObject(e, "max", t->max) &&
             (is_bool   ? cJSON_AddBoolToObject(e, "default", t->def != 0.0) != NULL
              : is_enum ? cJSON_AddStringToObject(e, "default", t->choices[(int)t->def]) != NULL
                        : cJSON_AddNumberToObject(e, "default", t->def) != NULL) &&
             cJSON_AddStringToObject(e, "unit", t->unit ? t->unit : "") &&
             cJSON_AddStringToObject(e, "help", t->help ? t->help : "");
        /* the slider hint: only "log" is sent, an absent "scale" means linear */
        if (ok && t->scale == CORE_PARAM_LOG) ok = cJSON_AddStringToObject(e, "scale", "log") != NULL;
        if (ok && is_enum) ok = add_names(e, "choices", t->choices, (size_t)t->max + 1);
        if (ok && t->solvers) {
            size_t n_solvers = 0;
            while (t->solvers[n_solvers]) n_solvers++;
            ok = add_names(e, "solvers", t->solvers, n_solvers);
        }
    }
    if (!ok) {
        cJSON_Delete(arr);
        return NULL;
    }
    return arr;
}

static cJSON *string_array(const char *const *names, size_t n)
{
    cJSON *arr = cJSON_CreateArray();
    for (size_t i = 0; arr && i < n; i++) {
        cJSON *s = cJSON_CreateString(names[i]);
        if (!s || !cJSON_AddItemToArray(arr, s)) {
            cJSON_Delete(s);
            cJSON_Delete(arr);
            return NULL;
        }
    }
    return arr;
}

/* Adds item under name; deletes item and returns false when item is NULL or adding fails. */
static bool add_item(cJSON *obj, const char *name, cJSON *item)
{
    if (item && cJSON_AddItemToObject(obj, name, item)) return true;
    cJSON_Delete(item);
    return false;
}

static cJSON *anim_object(const proto_anim *a)
{
    cJSON *o = cJSON_CreateObject();
    if (o && cJSON_AddStringToObject(o, "preset", a->preset ? a->preset : "none") &&
        cJSON_AddNumberToObject(o, "speed", a->speed))
        return o;
    cJSON_Delete(o);
    return NULL;
}

static bool add_state_fields(cJSON *o, const proto_state *s)
{
    return cJSON_AddBoolToObject(o, "paused", s->paused) && cJSON_AddNumberToObject(o, "sim_time", s->sim_time) &&
           cJSON_AddNumberToObject(o, "steps", (double)s->steps) && add_item(o, "animation", anim_object(&s->animation));
}

char *proto_build_state(const proto_id *id, const proto_state *s)
{
    cJSON *o = new_message("state", id);
    return finish(o, o && add_state_fields(o, s));
}

static cJSON *stream_object(const proto_stream *s)
{
    cJSON *o = cJSON_CreateObject();
    if (o && cJSON_AddStringToObject(o, "codec", s->codec ? s->codec : "") &&
        cJSON_AddNumberToObject(o, "stride", s->stride) && cJSON_AddNumberToObject(o, "strands", s->strands) &&
        cJSON_AddNumberToObject(o, "max_error", s->max_error) && cJSON_AddNumberToObject(o, "max_rate", s->max_rate) &&
        cJSON_AddNumberToObject(o, "rate", s->rate) && cJSON_AddNumberToObject(o, "frame_rate", s->frame_rate) &&
        cJSON_AddNumberToObject(o, "keyframe_interval", s->keyframe_interval))
        return o;
    cJSON_Delete(o);
    return NULL;
}

char *proto_build_subscribed(const proto_id *id, const proto_stream *s)
{
    cJSON *o = new_message("subscribed", id);
    return finish(o, o && add_item(o, "stream", stream_object(s)));
}

char *proto_build_groom(const proto_groom_json *g)
{
    cJSON *o = new_message("groom", NULL);
    bool ok = o && add_item(o, "groom", cJSON_CreateRaw(g->groom)) && add_item(o, "colliders", cJSON_CreateRaw(g->colliders)) &&
              add_item(o, "collider_mesh", cJSON_CreateRaw(g->mesh ? g->mesh : "null"));
    return finish(o, ok);
}

static cJSON *head_object(core_xform x)
{
    float pos[3] = { x.pos.x, x.pos.y, x.pos.z }, rot[4] = { x.rot.x, x.rot.y, x.rot.z, x.rot.w };
    cJSON *o = cJSON_CreateObject();
    if (o && add_item(o, "position", proto_json_float_array(pos, 3)) &&
        add_item(o, "orientation", proto_json_float_array(rot, 4)))
        return o;
    cJSON_Delete(o);
    return NULL;
}

static cJSON *limits_object(void)
{
    cJSON *o = cJSON_CreateObject();
    if (o && cJSON_AddNumberToObject(o, "max_message", PROTO_MAX_MESSAGE) &&
        cJSON_AddNumberToObject(o, "max_strands", PROTO_MAX_STRANDS) &&
        cJSON_AddNumberToObject(o, "max_verts", PROTO_MAX_VERTS) &&
        cJSON_AddNumberToObject(o, "max_vertices", PROTO_MAX_VERTICES) &&
        cJSON_AddNumberToObject(o, "max_step", PROTO_MAX_STEP) && cJSON_AddNumberToObject(o, "max_speed", PROTO_MAX_SPEED) &&
        cJSON_AddNumberToObject(o, "max_stride", PROTO_MAX_STRIDE) &&
        cJSON_AddNumberToObject(o, "min_error", PROTO_MIN_ERROR) && cJSON_AddNumberToObject(o, "max_error", PROTO_MAX_ERROR) &&
        cJSON_AddNumberToObject(o, "max_rate", PROTO_MAX_RATE))
        return o;
    cJSON_Delete(o);
    return NULL;
}

char *proto_build_hello(const proto_hello *h)
{
    static const char *const caps[] = { "params", "motion", "presets", "reset", "pause",
                                        "step",   "groom",  "subscribe", "keyframe", "stats", "auth" };
    cJSON *o = new_message("hello", NULL);
    bool ok = o && cJSON_AddStringToObject(o, "server", h->server) && cJSON_AddStringToObject(o, "version", h->version) &&
              cJSON_AddNumberToObject(o, "protocol", PROTO_VERSION) &&
              cJSON_AddStringToObject(o, "subprotocol", PROTO_SUBPROTOCOL) &&
              cJSON_AddNumberToObject(o, "client", h->client) && cJSON_AddStringToObject(o, "room", h->room ? h->room : PROTO_DEFAULT_ROOM) &&
              cJSON_AddStringToObject(o, "access", h->token_required ? "token" : "open") &&
              add_item(o, "capabilities", string_array(caps, sizeof caps / sizeof caps[0])) &&
              add_item(o, "groom", cJSON_CreateRaw(h->groom->groom)) &&
              add_item(o, "colliders", cJSON_CreateRaw(h->groom->colliders)) &&
              add_item(o, "collider_mesh", cJSON_CreateRaw(h->groom->mesh ? h->groom->mesh : "null")) &&
              add_item(o, "head", head_object(h->head));
    cJSON *params = ok ? cJSON_CreateObject() : NULL;
    ok = ok && add_item(o, "params", params) && add_item(params, "schema", param_schema(h->params, h->nparams)) &&
         add_item(params, "values", param_values(h->params, h->nparams, h->values)) &&
         add_item(o, "presets", string_array(h->presets, h->npresets)) && add_item(o, "animation", anim_object(&h->animation));
    cJSON *grooms = ok ? cJSON_CreateObject() : NULL;
    ok = ok && add_item(o, "grooms", grooms) && add_item(grooms, "styles", string_array(h->styles, h->nstyles)) &&
         add_item(grooms, "files", string_array(h->files, h->nfiles)) &&
         add_item(grooms, "colliders", string_array(h->meshes, h->nmeshes)) && add_item(o, "stream", stream_object(&h->stream));
    cJSON *state = ok ? cJSON_CreateObject() : NULL;
    ok = ok && add_item(o, "state", state) && add_state_fields(state, &h->state) && add_item(o, "limits", limits_object());
    return finish(o, ok);
}

char *proto_build_stats(const proto_stats *s)
{
    cJSON *o = new_message("stats", NULL);
    bool ok = o && cJSON_AddNumberToObject(o, "steps_per_s", s->steps_per_s) &&
              cJSON_AddNumberToObject(o, "step_ms", s->step_ms) && cJSON_AddNumberToObject(o, "encode_ms", s->encode_ms) &&
              cJSON_AddNumberToObject(o, "clients", s->clients) && cJSON_AddNumberToObject(o, "sim_time", s->sim_time) &&
              cJSON_AddNumberToObject(o, "steps", (double)s->steps) &&
              cJSON_AddNumberToObject(o, "nan_resets", (double)s->nan_resets);
    return finish(o, ok);
}
