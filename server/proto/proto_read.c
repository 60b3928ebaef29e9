/* proto: reads what a client tool needs from server messages (the type, an ok's step, a hello's
 * summary). */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "proto.h"

static double number(const cJSON *o, const char *key)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

static void string(const cJSON *o, const char *key, char *out, size_t cap)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    snprintf(out, cap, "%s", cJSON_IsString(v) ? v->valuestring : "");
}

core_status proto_read_envelope(const char *text, size_t len, char *type, size_t cap, proto_id *id)
{
    cJSON *root = cJSON_ParseWithLength(text, len);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(root, "type");
    const cJSON *i = cJSON_GetObjectItemCaseSensitive(root, "id");
    core_status st = cJSON_IsString(t) ? CORE_OK : CORE_EFORMAT;
    snprintf(type, cap, "%s", st == CORE_OK ? t->valuestring : "");
    memset(id, 0, sizeof *id);
    if (cJSON_IsNumber(i) && isfinite(i->valuedouble)) {
        id->kind = PROTO_ID_NUMBER;
        id->num = i->valuedouble;
    } else if (cJSON_IsString(i) && strlen(i->valuestring) <= PROTO_MAX_ID) {
        id->kind = PROTO_ID_STRING;
        snprintf(id->str, sizeof id->str, "%s", i->valuestring);
    }
    cJSON_Delete(root);
    return st;
}

bool proto_id_equal(const proto_id *a, const proto_id *b)
{
    if (a->kind != b->kind) return false;
    if (a->kind == PROTO_ID_NUMBER) return a->num == b->num;
    return a->kind == PROTO_ID_NONE || strcmp(a->str, b->str) == 0;
}

core_status proto_read_ok_step(const char *text, size_t len, uint64_t *step)
{
    cJSON *root = cJSON_ParseWithLength(text, len);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(root, "type");
    const double s = number(root, "step");
    const bool ok = cJSON_IsString(t) && strcmp(t->valuestring, "ok") == 0 && s >= 0.0 && s <= 9007199254740992.0 &&
                    s == floor(s);
    if (ok) *step = (uint64_t)s;
    cJSON_Delete(root);
    return ok ? CORE_OK : CORE_EFORMAT;
}

core_status proto_read_hello(const char *text, size_t len, proto_hello_info *out, core_err *err)
{
    memset(out, 0, sizeof *out);
    cJSON *root = cJSON_ParseWithLength(text, len);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(root, "type");
    if (!cJSON_IsString(t) || strcmp(t->valuestring, "hello") != 0) {
        cJSON_Delete(root);
        return core_fail(err, CORE_EFORMAT, "not a hello message");
    }
    const cJSON *g = cJSON_GetObjectItemCaseSensitive(root, "groom");
    const cJSON *s = cJSON_GetObjectItemCaseSensitive(root, "stream");
    string(root, "server", out->server, sizeof out->server);
    string(root, "version", out->version, sizeof out->version);
    string(g, "source", out->source, sizeof out->source);
    out->protocol = number(root, "protocol");
    out->client = number(root, "client");
    out->strands = number(g, "strands");
    out->verts = number(g, "verts");
    out->stride = number(s, "stride");
    out->max_error = number(s, "max_error");
    out->rate = number(s, "rate");
    out->frame_rate = number(s, "frame_rate");
    cJSON_Delete(root);
    if (!(out->strands >= 1 && out->verts >= 2 && out->protocol >= 1))
        return core_fail(err, CORE_EFORMAT, "the hello lacks the protocol version or the groom's counts");
    return CORE_OK;
}
