/* app: set_groom on the sim thread: checks the request, hands the loads to the loader thread,
 * and swaps the loaded groom in at a step boundary (new simulation, streams re-keyed). */
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app_cmd.h"
#include "app_cmd_groom.h"
#include "app_play.h"
#include "app_sim.h"

/* The end of a set_groom: the next may come (from the reply on, a client may send it). */
static void done(app_world *w) { atomic_fetch_sub(w->grooms_pending, 1); }

/* Ends a set_groom with an error reply. */
static void refuse(app_world *w, uint32_t client, const proto_msg *m, proto_code code, const char *field, const char *msg)
{
    done(w);
    app_reply_fail(w->out, client, &m->id, code, field, msg);
}

/* Fills the loader's job from the request; false (after replying) when it cannot be served. */
static bool make_job(app_world *w, uint32_t client, const proto_msg *m, app_load_job *j)
{
    const app_assets *as = w->assets;
    if (m->u.set_groom.collider_mode == PROTO_COLLIDER_FILE &&
        app_assets_find(as->meshes, as->nmeshes, m->u.set_groom.collider) == as->nmeshes) {
        refuse(w, client, m, PROTO_ERR_NOT_FOUND, "collider",
               "no such collision mesh file in the asset folder (see hello.grooms.colliders)");
        return false;
    }
    size_t fi = 0;
    if (m->u.set_groom.is_file && (fi = app_assets_find(as->files, as->nfiles, m->u.set_groom.file)) == as->nfiles) {
        refuse(w, client, m, PROTO_ERR_NOT_FOUND, "file", "no such groom file in the asset folder (see hello.grooms.files)");
        return false;
    }
    uint32_t strands = m->u.set_groom.strands ? m->u.set_groom.strands : w->groom.g.nstrands;
    uint32_t verts = m->u.set_groom.verts;
    if (!m->u.set_groom.is_file) {
        if (!verts) verts = w->groom.g.nverts;
        if ((uint64_t)strands * verts > PROTO_MAX_VERTICES) {
            refuse(w, client, m, PROTO_ERR_TOO_LARGE, "strands", "strands x verts is over the vertex limit");
            return false;
        }
    }
    memset(j, 0, sizeof *j);
    j->verts = verts;
    j->sim = (sim_desc){ .backend = w->backend, .threads = w->d->threads, .device = w->d->device };
    j->params = w->params;
    if (w->budget.dftl > 0.0) {
        j->particles_per_s = app_budget_rate(&w->budget, w->params.solver);
        j->min_rate = w->d->min_step_rate;
    }
    if (m->u.set_groom.is_file) {
        snprintf(j->groom_path, sizeof j->groom_path, "%s/%s", w->d->assets_dir, as->files[fi]);
        j->label = as->files[fi];
    } else {
        j->style = w->styles[m->u.set_groom.style];
        j->strands = strands;
        j->seed = m->u.set_groom.has_seed ? m->u.set_groom.seed : w->d->seed;
    }
    if (m->u.set_groom.collider_mode == PROTO_COLLIDER_FILE) {
        size_t mi = app_assets_find(as->meshes, as->nmeshes, m->u.set_groom.collider);
        snprintf(j->mesh_path, sizeof j->mesh_path, "%s/%s", w->d->assets_dir, as->meshes[mi]);
        snprintf(j->mesh_label, sizeof j->mesh_label, "%s", as->meshes[mi]);
    } else if (m->u.set_groom.collider_mode == PROTO_COLLIDER_KEEP && w->groom.g.mesh) {
        core_err err;
        if (core_mesh_copy(&j->keep, w->groom.g.mesh, &err) != CORE_OK) {
            refuse(w, client, m, PROTO_ERR_FAILED, "collider", err.msg);
            return false;
        }
        j->has_keep = true;
        snprintf(j->mesh_label, sizeof j->mesh_label, "%s", w->groom.collider);
    }
    return true;
}

void app_cmd_set_groom(app_world *w, uint32_t client, const proto_msg *m)
{
    app_loader *l = &w->loader;
    if (l->running) { /* grooms_pending makes this impossible; refuse rather than race */
        refuse(w, client, m, PROTO_ERR_BUSY, "", "a groom change is already in progress");
        return;
    }
    app_load_job job;
    if (!make_job(w, client, m, &job)) return;
    memset(l, 0, sizeof *l);
    l->client = client;
    l->msg = *m;
    l->job = job;
    core_err err;
    if (app_loader_start(l, w->mb, &err) != CORE_OK) refuse(w, client, m, PROTO_ERR_FAILED, "", err.msg);
}

/* Makes the loaded groom and its simulation (taken over from l) the live ones, with the
 * parameters, head pose and streams of now; pointer moves and a reset, no allocation. True when
 * the solver was hairmesh and the new groom has no hair mesh: it is dftl now. */
static bool swap_groom(app_world *w, app_loader *l)
{
    core_err err;
    const bool fell_back = w->params.solver == SIM_SOLVER_HAIRMESH && !l->g.g.hairmesh;
    if (fell_back) w->params.solver = SIM_SOLVER_DFTL;
    if (sim_change(&l->sim, &l->g.g, &w->params, &err) != CORE_OK) /* validated when they were set */
        core_log(CORE_LOG_ERROR, "app", "the new groom's simulation refused the current parameters: %s", err.msg);
    sim old = w->sim;
    w->sim = l->sim;
    memset(&l->sim, 0, sizeof l->sim);
    free(w->xyz);
    w->xyz = l->xyz;
    l->xyz = NULL;
    app_groom_free(&w->groom);
    w->groom = l->g;
    memset(&l->g, 0, sizeof l->g);
    app_sim_arm(w);
    app_world_set_head(w, app_anim_pose(&w->anim));
    app_world_reset(w);
    const core_hairmesh *hm = w->groom.g.hairmesh;
    app_streams_regroom(&w->streams, w->groom.g.nstrands, w->groom.g.nverts, hm ? hm->ncols : 0, hm ? hm->nlayers : 0);
    w->dirty = true;
    sim_destroy(&old);
    return fell_back;
}

/* Tells every client the solver the loader fell back to (a strand groom while hairmesh ran). */
static void announce_solver(app_world *w)
{
    bool changed[PROTO_MAX_PARAMS] = { false };
    for (size_t i = 0; i < w->nparams; i++) changed[i] = w->ptable[i].offset == offsetof(sim_params, solver);
    app_send(w->out, NET_ALL, proto_build_params(NULL, w->ptable, w->nparams, &w->params, changed, -1),
             APP_ANNOUNCE_PARAMS);
}

bool app_cmd_groom_poll(app_world *w)
{
    app_loader *l = &w->loader;
    if (!app_loader_collect(l)) return false;
    uint32_t client = l->client;
    const proto_msg *m = &l->msg;
    /* the solver may have changed while it loaded: the groom must fit the one it will run under */
    if (l->st == CORE_OK &&
        app_budget_check(app_budget_rate(&w->budget, w->params.solver), l->job.min_rate, w->params.solver, l->g.g.nstrands,
                         l->g.g.nverts, &l->err) != CORE_OK) {
        l->st = CORE_EINVAL;
        l->code = PROTO_ERR_TOO_LARGE;
        l->field = l->job.groom_path[0] ? "file" : "style";
    }
    const bool swapped = l->st == CORE_OK;
    if (!swapped) {
        refuse(w, client, m, l->code, l->field, l->err.msg);
    } else {
        done(w); /* before the replies: a client may send the next set_groom on seeing them */
        unsigned long long t0 = core_now_ns();
        const bool fell_back = swap_groom(w, l);
        app_play_record(w, m);
        app_groom_publish(w->out, w->d->room, &w->groom); /* before the groom message that names it */
        core_log(CORE_LOG_INFO, "app",
                 "client %u: groom %s, %u strands x %u vertices (load %.0f ms), collider %s (load %.0f ms, grid %.0f ms), "
                 "simulation %.0f ms; off the sim thread %.0f ms, swap on it %.1f ms",
                 client, w->groom.source, w->groom.g.nstrands, w->groom.g.nverts, l->groom_ms,
                 w->groom.collider[0] ? w->groom.collider : "none", w->groom.mesh_ms, w->groom.sdf_ms, l->sim_ms,
                 l->total_ms, (double)(core_now_ns() - t0) / 1e6);
        app_reply_ok(w->out, client, m, 0); /* the new groom's simulation starts at step 0 */
        app_send(w->out, NET_ALL, proto_build_groom(&w->groom.json), APP_ANNOUNCE_GROOM);
        if (fell_back) announce_solver(w);
        app_cmd_hairmesh_fallback(w); /* after the groom message, before any frame of the new groom */
    }
    app_loader_clear(l);
    return swapped;
}
