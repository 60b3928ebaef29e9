/* scen: what a client knows of the server: the hello, the parameters and state announced since,
 * the groom and colliders the checks measure against, and the head pose frames were made under. */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scen.h"

#define SCEN_BLEND_S 0.4 /* PROTOCOL.md: a preset change blends the head over 0.4 s of sim time */

/* n floats of a JSON number array into out (malloc'd); false when it is not such an array. */
static bool float_array(const cJSON *a, size_t n, float **out)
{
    if (!cJSON_IsArray(a) || (size_t)cJSON_GetArraySize(a) != n || n == 0) return false;
    float *v = malloc(n * sizeof *v);
    if (!v) return false;
    size_t i = 0;
    for (const cJSON *e = a->child; e; e = e->next, i++) {
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble)) {
            free(v);
            return false;
        }
        v[i] = (float)e->valuedouble;
    }
    *out = v;
    return true;
}

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

/* The per-strand rest segment lengths of a groom object (hello.groom or groom.groom) into
 * *out (n floats). The one place they are read, should they move to an HTTP resource. */
static bool read_rest_lengths(const cJSON *groom, uint32_t n, float **out)
{
    return float_array(cJSON_GetObjectItemCaseSensitive(groom, "rest_lengths"), n, out);
}

/* Reads a groom object and the colliders array into w (replacing what it held). */
static core_status read_groom(scen_world *w, const cJSON *g, const cJSON *cols, core_err *err)
{
    const cJSON *ns = cJSON_GetObjectItemCaseSensitive(g, "strands"), *nv = cJSON_GetObjectItemCaseSensitive(g, "verts");
    if (!cJSON_IsNumber(ns) || !cJSON_IsNumber(nv) || !(ns->valuedouble >= 1 && ns->valuedouble <= 1 << 24) ||
        !(nv->valuedouble >= 2 && nv->valuedouble <= 4096))
        return core_fail(err, CORE_EFORMAT, "groom.strands / groom.verts missing or out of range");
    uint32_t strands = (uint32_t)ns->valuedouble, verts = (uint32_t)nv->valuedouble;
    float *rest = NULL, *roots = NULL;
    if (!read_rest_lengths(g, strands, &rest))
        return core_fail(err, CORE_EFORMAT, "groom.rest_lengths: want %u finite numbers", strands);
    if (!float_array(cJSON_GetObjectItemCaseSensitive(g, "roots"), 3u * strands, &roots)) {
        free(rest);
        return core_fail(err, CORE_EFORMAT, "groom.roots: want %u finite numbers", 3u * strands);
    }
    scen_collider cs[SCEN_MAX_COLLIDERS];
    int nc = 0;
    for (const cJSON *c = cJSON_IsArray(cols) ? cols->child : NULL; c; c = c->next) {
        const cJSON *kind = cJSON_GetObjectItemCaseSensitive(c, "kind");
        const char *k = cJSON_IsString(kind) ? kind->valuestring : "";
        if (nc == SCEN_MAX_COLLIDERS) {
            free(rest);
            free(roots);
            return core_fail(err, CORE_EFORMAT, "colliders: more than %d", SCEN_MAX_COLLIDERS);
        }
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
        if (!ok) {
            free(rest);
            free(roots);
            return core_fail(err, CORE_EFORMAT, "colliders[%d]: not a sphere, capsule or ellipsoid with finite fields and positive radii", nc);
        }
        nc++;
    }
    free(w->rest_lengths);
    free(w->roots);
    w->rest_lengths = rest;
    w->roots = roots;
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

static void set_preset(scen_world *w, const cJSON *animation)
{
    const cJSON *p = cJSON_GetObjectItemCaseSensitive(animation, "preset");
    if (cJSON_IsString(p)) snprintf(w->preset, sizeof w->preset, "%s", p->valuestring);
}

core_status scen_world_hello(scen_world *w, const char *text, size_t len, core_err *err)
{
    memset(w, 0, sizeof *w);
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
    const cJSON *head = cJSON_GetObjectItemCaseSensitive(root, "head");
    double p[3], q[4];
    if (!doubles(cJSON_GetObjectItemCaseSensitive(head, "position"), p, 3) ||
        !doubles(cJSON_GetObjectItemCaseSensitive(head, "orientation"), q, 4)) {
        st = core_fail(err, CORE_EFORMAT, "head: want position [x,y,z] and orientation [x,y,z,w]");
        goto out;
    }
    snprintf(w->preset, sizeof w->preset, "none");
    set_preset(w, cJSON_GetObjectItemCaseSensitive(root, "animation"));
    w->base.pos = core_v3((float)p[0], (float)p[1], (float)p[2]);
    w->base.rot = quat_of(q);
    /* under a running preset hello.head is the animated pose, not the one presets run on */
    w->base_known = strcmp(w->preset, "none") == 0;
    w->heads[0] = w->base;
    w->nheads = w->base_known;
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
    const cJSON *stime = cJSON_GetObjectItemCaseSensitive(w->state, "sim_time");
    w->last_state_time = cJSON_IsNumber(stime) ? stime->valuedouble : 0.0;
    w->hello = root;
    root = NULL;
    if (!w->params) w->params = cJSON_CreateObject();
out:
    cJSON_Delete(root);
    if (st != CORE_OK) scen_world_free(w);
    return st;
}

/* A state message (hello.state's shape): the preset, and a preset change's blend. */
static void take_state(scen_world *w, const cJSON *m)
{
    char before[32];
    snprintf(before, sizeof before, "%s", w->preset);
    set_preset(w, cJSON_GetObjectItemCaseSensitive(m, "animation"));
    const cJSON *stime = cJSON_GetObjectItemCaseSensitive(m, "sim_time");
    double t = cJSON_IsNumber(stime) ? stime->valuedouble : w->last_state_time;
    if (t < w->last_state_time && w->blend_until > 0) w->blend_until = t + SCEN_BLEND_S; /* a reset restarts time */
    w->last_state_time = t;
    bool was_moving = strcmp(before, "none") != 0, moving = strcmp(w->preset, "none") != 0;
    if (was_moving && !moving) {
        /* the head blends back to the last motion pose */
        double dt = 1.0 / 60.0;
        const cJSON *d = cJSON_GetObjectItemCaseSensitive(w->params, "dt");
        if (cJSON_IsNumber(d) && d->valuedouble > 0) dt = d->valuedouble;
        w->blend_until = t + SCEN_BLEND_S + 2.0 * dt;
        w->heads[0] = w->base;
        w->nheads = w->base_known;
    } else if (moving) {
        w->nheads = 0;
    }
}

void scen_world_text(scen_world *w, const char *text)
{
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
        take_state(w, m);
    } else if (strcmp(t->valuestring, "groom") == 0) {
        core_err err;
        read_groom(w, cJSON_GetObjectItemCaseSensitive(m, "groom"), cJSON_GetObjectItemCaseSensitive(m, "colliders"), &err);
        cJSON_DeleteItemFromObjectCaseSensitive(m, "type");
        keep(&w->groom, m);
    }
out:
    cJSON_Delete(m);
}

void scen_world_sent(scen_world *w, const char *msg)
{
    cJSON *m = cJSON_Parse(msg);
    const cJSON *t = cJSON_GetObjectItemCaseSensitive(m, "type");
    double p[3], q[4];
    if (cJSON_IsString(t) && strcmp(t->valuestring, "motion") == 0 &&
        doubles(cJSON_GetObjectItemCaseSensitive(m, "position"), p, 3) &&
        doubles(cJSON_GetObjectItemCaseSensitive(m, "orientation"), q, 4) && (q[0] || q[1] || q[2] || q[3])) {
        core_xform x = { core_v3((float)p[0], (float)p[1], (float)p[2]), quat_of(q) };
        w->base = x;
        w->base_known = true;
        if (strcmp(w->preset, "none") == 0) {
            /* frames in flight still show the old pose: either is right until a frame shows the new one */
            if (w->nheads > 0) w->heads[1] = w->heads[0];
            w->nheads = w->nheads > 0 ? 2 : 1;
            w->heads[0] = x;
        }
    }
    cJSON_Delete(m);
}

int scen_world_head(const scen_world *w, const codec_frame_info *info, core_xform *out)
{
    if (strcmp(w->preset, "none") != 0 || info->sim.sim_time < w->blend_until) return 0;
    for (int k = 0; k < w->nheads; k++) out[k] = w->heads[k];
    return w->nheads;
}

void scen_world_head_matched(scen_world *w, int k)
{
    if (k == 0 && w->nheads > 1) w->nheads = 1;
}

double scen_world_frame_step(const scen_world *w, const codec_frame_info *info)
{
    const cJSON *d = cJSON_GetObjectItemCaseSensitive(w->params, "dt");
    double dt = cJSON_IsNumber(d) && d->valuedouble > 0 ? d->valuedouble : 1.0 / 60.0;
    return floor(info->sim.sim_time / dt + 0.5);
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
