/* proto: pre-renders a groom's JSON (counts, roots, rest lengths, bounds, colliders, collision mesh) once per groom. */
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

static char *groom_text(const proto_groom *pg, core_err *err, core_status *st)
{
    const core_groom *g = pg->groom;
    size_t ns = g->nstrands, nv = g->nverts;
    float *lens = malloc((ns ? ns : 1) * sizeof *lens);
    float *roots = malloc((ns ? ns : 1) * 3 * sizeof *roots);
    float bounds[6] = { FLT_MAX, FLT_MAX, FLT_MAX, -FLT_MAX, -FLT_MAX, -FLT_MAX };
    if (!lens || !roots) {
        free(lens);
        free(roots);
        *st = core_fail(err, CORE_ENOMEM, "out of memory rendering the groom");
        return NULL;
    }
    for (size_t s = 0; s < ns; s++) {
        const float *p = g->pos + 3 * s * nv;
        double len = 0.0;
        for (size_t v = 0; v < nv; v++) {
            for (int k = 0; k < 3; k++) {
                if (p[3 * v + k] < bounds[k]) bounds[k] = p[3 * v + k];
                if (p[3 * v + k] > bounds[3 + k]) bounds[3 + k] = p[3 * v + k];
            }
            if (v) {
                double dx = p[3 * v] - p[3 * v - 3], dy = p[3 * v + 1] - p[3 * v - 2], dz = p[3 * v + 2] - p[3 * v - 1];
                len += sqrt(dx * dx + dy * dy + dz * dz);
            }
        }
        lens[s] = nv > 1 ? (float)(len / (double)(nv - 1)) : 0.0f;
        memcpy(roots + 3 * s, p, 3 * sizeof *p);
    }
    if (ns == 0) memset(bounds, 0, sizeof bounds);
    proto_sb sb = { 0 };
    char buf[160];
    put_str(&sb, "{\"source\":");
    put_json_string(&sb, pg->source ? pg->source : "");
    snprintf(buf, sizeof buf, ",\"strands\":%zu,\"verts\":%zu,\"seed\":%llu,\"rest_lengths\":", ns, nv,
             (unsigned long long)pg->seed);
    put_str(&sb, buf);
    proto_sb_floats(&sb, lens, ns, 1);
    put_str(&sb, ",\"roots\":");
    proto_sb_floats(&sb, roots, 3 * ns, 1);
    put_str(&sb, ",\"bounds\":");
    proto_sb_floats(&sb, bounds, 6, 1);
    put_str(&sb, "}");
    free(lens);
    free(roots);
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
