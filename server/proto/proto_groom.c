/* proto: pre-renders a groom's JSON (counts, bounds, where its data is, colliders, collision mesh) once per groom. */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "proto.h"
#include "proto_json.h"

static void put_str(proto_sb *sb, const char *s) { proto_sb_put(sb, s, strlen(s)); }

/* A JSON string literal of s (escaped by cJSON). */
static void put_json_string(proto_sb *sb, const char *s)
{
    cJSON *str = cJSON_CreateString(s);
    char *t = str ? cJSON_PrintUnformatted(str) : NULL;
    if (t) put_str(sb, t);
    else sb->failed = 1;
    cJSON_free(t);
    cJSON_Delete(str);
}

static void put_vec(proto_sb *sb, core_vec3 v)
{
    float f[3] = { v.x, v.y, v.z };
    proto_sb_floats(sb, f, 3, 1);
}

/* {"source":..,"strands":..,"verts":..,"seed":..,"bounds":[..],"url":..,"etag":..,"bytes":..,
 * "hairmesh":{"ncols":..,"nlayers":..,"nfaces":..,"nguides":..,"url":..,"etag":..,"bytes":..}|null}:
 * the per-strand arrays and the hair mesh's topology are in the binaries at the urls, not in the
 * JSON. */
static char *groom_text(const proto_groom *pg, core_err *err, core_status *st)
{
    const core_groom *g = pg->groom;
    size_t n = (size_t)g->nstrands * g->nverts;
    float bounds[6] = { FLT_MAX, FLT_MAX, FLT_MAX, -FLT_MAX, -FLT_MAX, -FLT_MAX };
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            bounds[k] = fminf(bounds[k], g->pos[3 * i + (size_t)k]);
            bounds[3 + k] = fmaxf(bounds[3 + k], g->pos[3 * i + (size_t)k]);
        }
    if (n == 0) memset(bounds, 0, sizeof bounds);
    const proto_data_ref *d = pg->data;
    proto_sb sb = { 0 };
    char buf[160];
    put_str(&sb, "{\"source\":");
    put_json_string(&sb, pg->source ? pg->source : "");
    snprintf(buf, sizeof buf, ",\"strands\":%u,\"verts\":%u,\"seed\":%llu,\"bounds\":", g->nstrands, g->nverts,
             (unsigned long long)pg->seed);
    put_str(&sb, buf);
    proto_sb_floats(&sb, bounds, 6, 1);
    put_str(&sb, ",\"url\":");
    put_json_string(&sb, d && d->url ? d->url : "");
    put_str(&sb, ",\"etag\":");
    put_json_string(&sb, d && d->etag ? d->etag : "");
    snprintf(buf, sizeof buf, ",\"bytes\":%llu,\"hairmesh\":", d ? (unsigned long long)d->bytes : 0ull);
    put_str(&sb, buf);
    const core_hairmesh *m = g->hairmesh;
    const proto_data_ref *h = pg->hairmesh;
    if (m && h) {
        snprintf(buf, sizeof buf, "{\"ncols\":%u,\"nlayers\":%u,\"nfaces\":%u,\"nguides\":%u,\"url\":", m->ncols,
                 m->nlayers, m->nfaces, m->nguides);
        put_str(&sb, buf);
        put_json_string(&sb, h->url ? h->url : "");
        put_str(&sb, ",\"etag\":");
        put_json_string(&sb, h->etag ? h->etag : "");
        snprintf(buf, sizeof buf, ",\"bytes\":%llu}}", (unsigned long long)h->bytes);
        put_str(&sb, buf);
    } else {
        put_str(&sb, "null}");
    }
    char *t = proto_sb_take(&sb);
    if (!t) *st = core_fail(err, CORE_ENOMEM, "out of memory rendering the groom");
    return t;
}

static char *colliders_text(const core_groom *g, core_err *err, core_status *st)
{
    proto_sb sb = { 0 };
    put_str(&sb, "[");
    for (uint32_t i = 0; i < g->ncolliders && i < CORE_MAX_COLLIDERS; i++) {
        const core_collider *c = &g->colliders[i];
        char buf[64];
        if (i) put_str(&sb, ",");
        switch (c->kind) {
        case CORE_COLLIDER_SPHERE:
            put_str(&sb, "{\"kind\":\"sphere\",\"center\":");
            put_vec(&sb, c->a);
            break;
        case CORE_COLLIDER_CAPSULE:
            put_str(&sb, "{\"kind\":\"capsule\",\"a\":");
            put_vec(&sb, c->a);
            put_str(&sb, ",\"b\":");
            put_vec(&sb, c->b);
            break;
        case CORE_COLLIDER_ELLIPSOID: {
            float q[4] = { c->rot.x, c->rot.y, c->rot.z, c->rot.w };
            put_str(&sb, "{\"kind\":\"ellipsoid\",\"center\":");
            put_vec(&sb, c->a);
            put_str(&sb, ",\"radii\":");
            put_vec(&sb, c->radii);
            put_str(&sb, ",\"rotation\":");
            proto_sb_floats(&sb, q, 4, 1);
            put_str(&sb, "}");
            continue;
        }
        }
        snprintf(buf, sizeof buf, ",\"radius\":%.9g}", proto_json_float(c->radius));
        put_str(&sb, buf);
    }
    put_str(&sb, "]");
    char *t = proto_sb_take(&sb);
    if (!t) *st = core_fail(err, CORE_ENOMEM, "out of memory rendering the colliders");
    return t;
}

/* {"source":..,"verts":..,"triangles":..,"bounds":[..],"url":..,"etag":..,"bytes":..,
 * "sdf":{"cell":..,"dims":[..],"origin":[..]}|null}, or null without a mesh. */
static char *mesh_text(const proto_groom *pg, core_err *err, core_status *st)
{
    const core_mesh *m = pg->groom->mesh;
    proto_sb sb = { 0 };
    if (!m || !pg->mesh) {
        put_str(&sb, "null");
    } else {
        float b[6] = { FLT_MAX, FLT_MAX, FLT_MAX, -FLT_MAX, -FLT_MAX, -FLT_MAX };
        for (size_t i = 0; i < m->nverts; i++)
            for (int k = 0; k < 3; k++) {
                b[k] = fminf(b[k], m->pos[3 * i + k]);
                b[3 + k] = fmaxf(b[3 + k], m->pos[3 * i + k]);
            }
        if (!m->nverts) memset(b, 0, sizeof b);
        char buf[160];
        put_str(&sb, "{\"source\":");
        put_json_string(&sb, pg->mesh->source ? pg->mesh->source : "");
        snprintf(buf, sizeof buf, ",\"verts\":%u,\"triangles\":%u,\"bounds\":", m->nverts, m->ntris);
        put_str(&sb, buf);
        proto_sb_floats(&sb, b, 6, 1);
        put_str(&sb, ",\"url\":");
        put_json_string(&sb, pg->mesh->url ? pg->mesh->url : "");
        put_str(&sb, ",\"etag\":");
        put_json_string(&sb, pg->mesh->etag ? pg->mesh->etag : "");
        snprintf(buf, sizeof buf, ",\"bytes\":%llu,\"sdf\":", (unsigned long long)pg->mesh->bytes);
        put_str(&sb, buf);
        const core_sdf *s = pg->groom->sdf;
        if (s) {
            snprintf(buf, sizeof buf, "{\"cell\":%.9g,\"dims\":[%u,%u,%u],\"origin\":", proto_json_float(s->cell), s->dims[0],
                     s->dims[1], s->dims[2]);
            put_str(&sb, buf);
            put_vec(&sb, s->origin);
            put_str(&sb, "}");
        } else {
            put_str(&sb, "null");
        }
        put_str(&sb, "}");
    }
    char *t = proto_sb_take(&sb);
    if (!t) *st = core_fail(err, CORE_ENOMEM, "out of memory rendering the collision mesh");
    return t;
}

core_status proto_groom_json_build(proto_groom_json *out, const proto_groom *g, core_err *err)
{
    core_status st = CORE_OK;
    memset(out, 0, sizeof *out);
    if (!g->data) return core_fail(err, CORE_EINVAL, "the groom's data binary is not described (proto_groom.data)");
    if (g->groom->hairmesh && !g->hairmesh)
        return core_fail(err, CORE_EINVAL, "the groom's hair mesh binary is not described (proto_groom.hairmesh)");
    out->groom = groom_text(g, err, &st);
    if (st == CORE_OK) out->colliders = colliders_text(g->groom, err, &st);
    if (st == CORE_OK) out->mesh = mesh_text(g, err, &st);
    if (st != CORE_OK) proto_groom_json_free(out);
    return st;
}

void proto_groom_json_free(proto_groom_json *j)
{
    cJSON_free(j->groom);
    cJSON_free(j->colliders);
    cJSON_free(j->mesh);
    memset(j, 0, sizeof *j);
}
