/* app: set_groom: the loads (groom, collision mesh, SDF: seconds for a large mesh) run on a
 * loader thread while the simulation keeps its pace; the swap happens on the sim thread. */
#define _GNU_SOURCE /* gettid */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <unistd.h>

#include "app_internal.h"
#include "groom/groom.h"

/* Index of name in list, or n. */
static size_t find_name(char *const *list, size_t n, const char *name)
{
    size_t i = 0;
    while (i < n && strcmp(list[i], name) != 0) i++;
    return i;
}

/* Loader thread: the groom, then its collision mesh and SDF, into l->g (or an error). */
static void *loader_main(void *arg)
{
    app_loader *l = arg;
    prctl(PR_SET_NAME, "sc-load");
    /* below the sim and net threads: on a busy machine the steps keep their pace */
    setpriority(PRIO_PROCESS, (id_t)gettid(), 10);
    unsigned long long t0 = core_now_ns();
    core_status st = l->groom_path[0]
                         ? app_groom_load_path(l->a, l->groom_path, l->label, l->verts, &l->g, &l->err)
                         : app_groom_load_style(l->a, l->style, l->strands, l->verts, l->seed, &l->g, &l->err);
    l->code = PROTO_ERR_FAILED;
    l->field = l->groom_path[0] ? "file" : "style";
    if (st == CORE_OK && (st = app_groom_check_size(&l->g, &l->err)) != CORE_OK) {
        l->code = PROTO_ERR_TOO_LARGE;
        app_groom_free(&l->g);
    }
    l->groom_ms = (double)(core_now_ns() - t0) / 1e6;
    if (st == CORE_OK && (l->mesh_path[0] || l->has_keep)) {
        l->field = "collider";
        core_mesh m = l->keep;
        memset(&l->keep, 0, sizeof l->keep);
        l->has_keep = false;
        unsigned long long t1 = core_now_ns();
        if (l->mesh_path[0]) st = groom_mesh_load_file(l->mesh_path, &m, &l->err);
        l->g.mesh_ms = (double)(core_now_ns() - t1) / 1e6;
        if (st == CORE_OK) st = app_groom_set_collider(&l->g, &m, l->mesh_label, &l->err);
        if (st != CORE_OK) app_groom_free(&l->g);
    }
    l->st = st;
    l->total_ms = (double)(core_now_ns() - t0) / 1e6;
    atomic_store(&l->done, true);
    app_mailbox_wake(&l->a->mb);
    return NULL;
}

/* The end of a set_groom: the next may come (from the reply on, a client may send it). */
static void done(app *a) { atomic_fetch_sub(&a->grooms_pending, 1); }

/* Ends a set_groom with an error reply. */
static void refuse(app *a, uint32_t client, const proto_msg *m, proto_code code, const char *field, const char *msg)
{
    done(a);
    app_reply_fail(a, client, &m->id, code, field, msg);
}

void app_set_groom(app *a, uint32_t client, const proto_msg *m)
{
    app_loader *l = &a->loader;
    if (l->running) { /* grooms_pending makes this impossible; refuse rather than race */
        refuse(a, client, m, PROTO_ERR_BUSY, "", "a groom change is already in progress");
        return;
    }
    if (m->u.set_groom.collider_mode == PROTO_COLLIDER_FILE &&
        find_name(a->meshes, a->nmeshes, m->u.set_groom.collider) == a->nmeshes) {
        refuse(a, client, m, PROTO_ERR_NOT_FOUND, "collider",
                       "no such collision mesh file in the asset folder (see hello.grooms.colliders)");
        return;
    }
    size_t fi = 0;
    if (m->u.set_groom.is_file && (fi = find_name(a->files, a->nfiles, m->u.set_groom.file)) == a->nfiles) {
        refuse(a, client, m, PROTO_ERR_NOT_FOUND, "file", "no such groom file in the asset folder (see hello.grooms.files)");
        return;
    }
    uint32_t strands = m->u.set_groom.strands ? m->u.set_groom.strands : a->groom.g.nstrands;
    uint32_t verts = m->u.set_groom.verts;
    if (!m->u.set_groom.is_file) {
        if (!verts) verts = a->groom.g.nverts;
        if ((uint64_t)strands * verts > PROTO_MAX_VERTICES) {
            refuse(a, client, m, PROTO_ERR_TOO_LARGE, "strands", "strands x verts is over the vertex limit");
            return;
        }
    }
    memset(l, 0, sizeof *l);
    l->a = a;
    l->client = client;
    l->msg = *m;
    l->verts = verts;
    if (m->u.set_groom.is_file) {
        snprintf(l->groom_path, sizeof l->groom_path, "%s/%s", a->d.assets_dir, a->files[fi]);
        l->label = a->files[fi];
    } else {
        l->style = a->styles[m->u.set_groom.style];
        l->strands = strands;
        l->seed = m->u.set_groom.has_seed ? m->u.set_groom.seed : a->d.seed;
    }
    if (m->u.set_groom.collider_mode == PROTO_COLLIDER_FILE) {
        size_t mi = find_name(a->meshes, a->nmeshes, m->u.set_groom.collider);
        snprintf(l->mesh_path, sizeof l->mesh_path, "%s/%s", a->d.assets_dir, a->meshes[mi]);
        snprintf(l->mesh_label, sizeof l->mesh_label, "%s", a->meshes[mi]);
    } else if (m->u.set_groom.collider_mode == PROTO_COLLIDER_KEEP && a->groom.g.mesh) {
        core_err err;
        if (core_mesh_copy(&l->keep, a->groom.g.mesh, &err) != CORE_OK) {
            refuse(a, client, m, PROTO_ERR_FAILED, "collider", err.msg);
            return;
        }
        l->has_keep = true;
        snprintf(l->mesh_label, sizeof l->mesh_label, "%s", a->groom.collider);
    }
    atomic_store(&l->done, false);
    if (pthread_create(&l->thread, NULL, loader_main, l) != 0) {
        core_mesh_free(&l->keep);
        refuse(a, client, m, PROTO_ERR_FAILED, "", "cannot start the groom loader thread");
        return;
    }
    l->running = true;
}

static bool swap_groom(app *a, app_groom *g, uint32_t client, const proto_msg *m)
{
    core_err err;
    sim fresh;
    sim_desc sd = { .backend = a->d.backend, .threads = a->d.threads, .device = a->d.device };
    if (sim_create(&fresh, &sd, &g->g, &a->params, &err) != CORE_OK) {
        app_reply_fail(a, client, &m->id, PROTO_ERR_FAILED, "", err.msg);
        return false;
    }
    size_t n = (size_t)g->g.nstrands * g->g.nverts * 3;
    float *xyz = malloc(n * sizeof *xyz);
    if (!xyz) {
        sim_destroy(&fresh);
        app_reply_fail(a, client, &m->id, PROTO_ERR_FAILED, "", "out of memory");
        return false;
    }
    sim_destroy(&a->sim);
    a->sim = fresh;
    free(a->xyz);
    a->xyz = xyz;
    app_groom_free(&a->groom);
    a->groom = *g;
    memset(g, 0, sizeof *g);
    sim_set_motion(&a->sim, app_anim_pose(&a->anim));
    app_reset_sim(a);
    app_tiers_reset(a);
    a->dirty = true;
    return true;
}

void app_regroom_poll(app *a)
{
    app_loader *l = &a->loader;
    if (!l->running || !atomic_load(&l->done)) return;
    pthread_join(l->thread, NULL);
    l->running = false;
    uint32_t client = l->client;
    const proto_msg *m = &l->msg;
    if (l->st != CORE_OK) {
        refuse(a, client, m, l->code, l->field, l->err.msg);
    } else {
        done(a); /* before the replies: a client may send the next set_groom on seeing them */
        unsigned long long t0 = core_now_ns();
        if (swap_groom(a, &l->g, client, m)) {
            app_publish_mesh(a); /* before the groom message that names it */
            core_log(CORE_LOG_INFO, "app",
                     "client %u: groom %s, %u strands x %u vertices (load %.0f ms), collider %s (load %.0f ms, grid %.0f ms); "
                     "off the sim thread %.0f ms, swap on it %.1f ms",
                     client, a->groom.source, a->groom.g.nstrands, a->groom.g.nverts, l->groom_ms,
                     a->groom.collider[0] ? a->groom.collider : "none", a->groom.mesh_ms, a->groom.sdf_ms, l->total_ms,
                     (double)(core_now_ns() - t0) / 1e6);
            app_reply_ok(a, client, m);
            app_send(a, NET_ALL, proto_build_groom(&a->groom.json), 0);
        }
    }
    app_groom_free(&l->g);
    core_mesh_free(&l->keep);
}

void app_regroom_join(app *a)
{
    app_loader *l = &a->loader;
    if (!l->running) return;
    pthread_join(l->thread, NULL);
    l->running = false;
    app_groom_free(&l->g);
    core_mesh_free(&l->keep);
}
