/* scen: what a client knows of the server: the hello, the parameters and state announced since,
 * the groom and colliders the checks measure against (the groom data fetched from groom.url). */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../proto/proto.h"
#include "scen.h"

static bool doubles(const cJSON *a, double *out, int n)
{
    if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != n) return false;
    int i = 0;
    for (const cJSON *e = a->child; e; e = e->next, i++) {
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble)) return false;
        out[i] = e->valuedouble;
    }
    return true;
}

static bool positive(const cJSON *v) { return cJSON_IsNumber(v) && isfinite(v->valuedouble) && v->valuedouble > 0; }

static core_quat quat_of(const double q[4])
{
    core_quat r = { (float)q[0], (float)q[1], (float)q[2], (float)q[3] };
    return core_q_norm(r);
}

static float f32_at(const unsigned char *p)
{
    uint32_t bits = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
    float f;
    memcpy(&f, &bits, 4);
    return f;
}

/* The per-strand rest segment lengths and rest roots of a groom object (hello.groom or
 * groom.groom: strands x verts) into *rest and *roots (malloc'd; both NULL when the data was
 * superseded: the server already serves a newer groom, whose groom message is on its way).
 * The one place they are read: fetched from the groom's url and checked against its etag and
 * bytes. CORE_EFORMAT or the fetch's status with "groom data: ..." in err. */
static core_status read_groom_data(scen_world *w, const cJSON *g, uint32_t strands, uint32_t verts, float **rest,
                                   float **roots, core_err *err)
{
    *rest = *roots = NULL;
    const cJSON *url = cJSON_GetObjectItemCaseSensitive(g, "url"), *etag = cJSON_GetObjectItemCaseSensitive(g, "etag"),
                *bytes = cJSON_GetObjectItemCaseSensitive(g, "bytes");
    if (!cJSON_IsString(url) || url->valuestring[0] != '/' || !cJSON_IsString(etag) || !cJSON_IsNumber(bytes) ||
        !(bytes->valuedouble >= PROTO_GROOM_HEADER && bytes->valuedouble <= (double)SCEN_GROOM_MAX_BYTES))
        return core_fail(err, CORE_EFORMAT, "groom data: groom.url (a path), groom.etag and groom.bytes (at most %llu) wanted",
                         (unsigned long long)SCEN_GROOM_MAX_BYTES);
    if (w->rest_lengths && strcmp(w->data_etag, etag->valuestring) == 0 && w->strands == strands && w->verts == verts) {
        *rest = w->rest_lengths; /* the bytes held are this version's */
        *roots = w->roots;
        w->rest_lengths = w->roots = NULL;
        return CORE_OK;
    }
    if (!w->fetch) return core_fail(err, CORE_EINVAL, "groom data: no way to fetch %.200s", url->valuestring);
    size_t want = (size_t)bytes->valuedouble, len = 0;
    uint8_t *bin = NULL;
    core_status st = w->fetch(w->fetch_user, url->valuestring, want, &bin, &len, err);
    if (st != CORE_OK) return st;
    char tag[17];
    proto_bin_etag(bin, len, tag);
    uint32_t ns = 0, nv = 0;
    if (strcmp(tag, etag->valuestring) != 0) {
        st = CORE_OK; /* superseded: no data until the next groom message */
    } else if (len != want) {
        st = core_fail(err, CORE_EFORMAT, "groom data: %.200s sent %zu bytes, groom.bytes says %zu", url->valuestring, len, want);
    } else if ((st = proto_groom_bin_read(bin, len, &ns, &nv, err)) != CORE_OK) {
        core_err inner = *err;
        st = core_fail(err, st, "groom data: %.200s: %s", url->valuestring, inner.msg);
    } else if (ns != strands || nv != verts) {
        st = core_fail(err, CORE_EFORMAT, "groom data: %.200s holds %u x %u, groom says %u x %u", url->valuestring, ns, nv,
                       strands, verts);
    } else {
        *rest = malloc((size_t)ns * sizeof **rest);
        *roots = malloc(3u * (size_t)ns * sizeof **roots);
        if (!*rest || !*roots) {
            st = core_fail(err, CORE_ENOMEM, "groom data: out of memory for %u strands", ns);
        } else {
            const unsigned char *p = bin + PROTO_GROOM_HEADER;
            for (size_t i = 0; i < ns; i++, p += 4) (*rest)[i] = f32_at(p);
            for (size_t i = 0; i < 3u * (size_t)ns; i++, p += 4) (*roots)[i] = f32_at(p);
            snprintf(w->data_etag, sizeof w->data_etag, "%s", tag);
        }
    }
    free(bin);
    if (st != CORE_OK) {
        free(*rest);
        free(*roots);
        *rest = *roots = NULL;
    }
    return st;
}

/* Reads a groom object and the colliders array into w (replacing what it held). */
static core_status read_groom(scen_world *w, const cJSON *g, const cJSON *cols, core_err *err)
{
    const cJSON *ns = cJSON_GetObjectItemCaseSensitive(g, "strands"), *nv = cJSON_GetObjectItemCaseSensitive(g, "verts");
    if (!cJSON_IsNumber(ns) || !cJSON_IsNumber(nv) || !(ns->valuedouble >= 1 && ns->valuedouble <= 1 << 24) ||
        !(nv->valuedouble >= 2 && nv->valuedouble <= 4096))
        return core_fail(err, CORE_EFORMAT, "groom.strands / groom.verts missing or out of range");
    uint32_t strands = (uint32_t)ns->valuedouble, verts = (uint32_t)nv->valuedouble;
    scen_collider cs[SCEN_MAX_COLLIDERS];
    int nc = 0;
    for (const cJSON *c = cJSON_IsArray(cols) ? cols->child : NULL; c; c = c->next) {
        const cJSON *kind = cJSON_GetObjectItemCaseSensitive(c, "kind");
        const char *k = cJSON_IsString(kind) ? kind->valuestring : "";
        if (nc == SCEN_MAX_COLLIDERS)
            return core_fail(err, CORE_EFORMAT, "colliders: more than %d", SCEN_MAX_COLLIDERS);
        scen_collider *o = &cs[nc];
        memset(o, 0, sizeof *o);
        double q[4] = { 0, 0, 0, 1 };
        bool ok;
        if (strcmp(k, "sphere") == 0) {
            o->kind = SCEN_SPHERE;
            const cJSON *r = cJSON_GetObjectItemCaseSensitive(c, "radius");
            ok = doubles(cJSON_GetObjectItemCaseSensitive(c, "center"), o->c, 3) && positive(r);
            o->radius = ok ? r->valuedouble : 0;
        } else if (strcmp(k, "capsule") == 0) {
            o->kind = SCEN_CAPSULE;
            const cJSON *r = cJSON_GetObjectItemCaseSensitive(c, "radius");
            ok = doubles(cJSON_GetObjectItemCaseSensitive(c, "a"), o->c, 3) &&
                 doubles(cJSON_GetObjectItemCaseSensitive(c, "b"), o->b, 3) && positive(r);
            o->radius = ok ? r->valuedouble : 0;
        } else if (strcmp(k, "ellipsoid") == 0) {
            o->kind = SCEN_ELLIPSOID;
            ok = doubles(cJSON_GetObjectItemCaseSensitive(c, "center"), o->c, 3) &&
                 doubles(cJSON_GetObjectItemCaseSensitive(c, "radii"), o->radii, 3) &&
                 (!cJSON_GetObjectItemCaseSensitive(c, "rotation") ||
                  doubles(cJSON_GetObjectItemCaseSensitive(c, "rotation"), q, 4)) &&
                 o->radii[0] > 0 && o->radii[1] > 0 && o->radii[2] > 0;
            o->rot = quat_of(q);
        } else {
            ok = false;
        }
        if (!ok)
            return core_fail(err, CORE_EFORMAT, "colliders[%d]: not a sphere, capsule or ellipsoid with finite fields and positive radii", nc);
        nc++;
    }
    float *rest, *roots;
    core_status st = read_groom_data(w, g, strands, verts, &rest, &roots, err);
    if (st != CORE_OK) return st;
    free(w->rest_lengths);
    free(w->roots);
    w->rest_lengths = rest;
    w->roots = roots;
    if (!rest) w->data_etag[0] = '\0';
    w->strands = strands;
    w->verts = verts;
    memcpy(w->colliders, cs, sizeof cs);
    w->ncolliders = nc;
    return CORE_OK;
}

/* Replaces *slot with a copy of v (detached from its tree). */
static void keep(void **slot, const cJSON *v)
{
    cJSON *copy = v ? cJSON_Duplicate(v, true) : NULL;
    if (v && !copy) return;
    cJSON_Delete(*slot);
    *slot = copy;
}

core_status scen_world_hello(scen_world *w, const char *text, size_t len, scen_fetch_fn fetch, void *fetch_user,
                             core_err *err)
{
    memset(w, 0, sizeof *w);
    w->fetch = fetch;
    w->fetch_user = fetch_user;
    cJSON *root = cJSON_ParseWithLength(text, len);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(root, "type");
    core_status st = CORE_OK;
    if (!cJSON_IsString(t) || strcmp(t->valuestring, "hello") != 0) {
        st = core_fail(err, CORE_EFORMAT, "not a hello message");
        goto out;
    }
    if ((st = read_groom(w, cJSON_GetObjectItemCaseSensitive(root, "groom"),
                         cJSON_GetObjectItemCaseSensitive(root, "colliders"), err)))
        goto out;
    const cJSON *params = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(root, "params"), "values");
    keep(&w->params, cJSON_IsObject(params) ? params : NULL);
    keep(&w->state, cJSON_GetObjectItemCaseSensitive(root, "state"));
    w->groom = cJSON_CreateObject();
    if (w->groom) {
        const char *parts[] = { "groom", "colliders", "collider_mesh" };
        for (int i = 0; i < 3; i++) {
            cJSON *v = cJSON_Duplicate(cJSON_GetObjectItemCaseSensitive(root, parts[i]), true);
            if (v) cJSON_AddItemToObject(w->groom, parts[i], v);
        }
    }
    w->hello = root;
    root = NULL;
    if (!w->params) w->params = cJSON_CreateObject();
out:
    cJSON_Delete(root);
    if (st != CORE_OK) scen_world_free(w);
    return st;
}

core_status scen_world_text(scen_world *w, const char *text, core_err *err)
{
    core_status st = CORE_OK;
    cJSON *m = cJSON_Parse(text);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(m, "type");
    if (!cJSON_IsString(t)) goto out;
    if (strcmp(t->valuestring, "params") == 0) {
        const cJSON *vals = cJSON_GetObjectItemCaseSensitive(m, "values");
        for (const cJSON *v = cJSON_IsObject(vals) ? vals->child : NULL; v; v = v->next) {
            cJSON *copy = cJSON_Duplicate(v, true);
            if (!copy) continue;
            if (cJSON_GetObjectItemCaseSensitive(w->params, v->string))
                cJSON_ReplaceItemInObjectCaseSensitive(w->params, v->string, copy);
            else
                cJSON_AddItemToObject(w->params, v->string, copy);
        }
    } else if (strcmp(t->valuestring, "state") == 0) {
        cJSON_DeleteItemFromObjectCaseSensitive(m, "type");
        keep(&w->state, m);
    } else if (strcmp(t->valuestring, "groom") == 0) {
        st = read_groom(w, cJSON_GetObjectItemCaseSensitive(m, "groom"), cJSON_GetObjectItemCaseSensitive(m, "colliders"), err);
        cJSON_DeleteItemFromObjectCaseSensitive(m, "type");
        keep(&w->groom, m);
    }
out:
    cJSON_Delete(m);
    return st;
}

core_xform scen_world_head(const codec_frame_info *info)
{
    const codec_sim_info *h = &info->sim;
    core_quat q = { h->head_rot[0], h->head_rot[1], h->head_rot[2], h->head_rot[3] };
    return (core_xform){ core_v3(h->head_pos[0], h->head_pos[1], h->head_pos[2]), core_q_norm(q) };
}

bool scen_world_collisions_on(const scen_world *w)
{
    const cJSON *c = cJSON_GetObjectItemCaseSensitive(w->params, "collisions");
    return !cJSON_IsFalse(c);
}

const void *scen_world_value(const scen_world *w, const char *what, const char *path)
{
    const cJSON *v = !strcmp(what, "hello")    ? w->hello
                     : !strcmp(what, "params") ? w->params
                     : !strcmp(what, "groom")  ? w->groom
                                               : w->state;
    char part[128];
    for (const char *p = path; v && *p;) {
        size_t n = strcspn(p, ".");
        if (n == 0 || n >= sizeof part) return NULL;
        memcpy(part, p, n);
        part[n] = '\0';
        p += n + (p[n] == '.');
        if (cJSON_IsArray(v)) {
            char *end;
            long i = strtol(part, &end, 10);
            v = *end || i < 0 ? NULL : cJSON_GetArrayItem(v, (int)i);
        } else {
            v = cJSON_GetObjectItemCaseSensitive(v, part);
        }
    }
    return v;
}

void scen_world_free(scen_world *w)
{
    cJSON_Delete(w->hello);
    cJSON_Delete(w->params);
    cJSON_Delete(w->state);
    cJSON_Delete(w->groom);
    free(w->rest_lengths);
    free(w->roots);
    memset(w, 0, sizeof *w);
}
