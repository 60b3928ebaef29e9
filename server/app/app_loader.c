/* app: the groom loader thread (groom, then collision mesh and SDF, then the simulation). */
#define _GNU_SOURCE /* gettid */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <unistd.h>

#include "app_budget.h"
#include "app_loader.h"
#include "groom/groom.h"

/* The simulation for the loaded groom and its positions buffer into l (or an error); dftl
 * instead of the hairmesh solver on a groom without a hair mesh (the swap tells the clients). */
static core_status make_sim(app_loader *l)
{
    unsigned long long t0 = core_now_ns();
    if (l->job.params.solver == SIM_SOLVER_HAIRMESH && !l->g.g.hairmesh) l->job.params.solver = SIM_SOLVER_DFTL;
    core_status st = sim_create(&l->sim, &l->job.sim, &l->g.g, &l->job.params, &l->err);
    if (st != CORE_OK) return st;
    size_t n = (size_t)l->g.g.nstrands * l->g.g.nverts * 3;
    l->xyz = malloc(n * sizeof *l->xyz);
    l->sim_ms = (double)(core_now_ns() - t0) / 1e6;
    if (!l->xyz) {
        sim_destroy(&l->sim);
        return core_fail(&l->err, CORE_ENOMEM, "out of memory for %zu positions", n / 3);
    }
    return CORE_OK;
}

/* Loader thread: the groom, then its collision mesh and SDF, into l->g, then the simulation
 * (or an error). */
static void *loader_main(void *arg)
{
    app_loader *l = arg;
    app_load_job *j = &l->job;
    prctl(PR_SET_NAME, "sc-load");
    /* below the sim and net threads: on a busy machine the steps keep their pace */
    setpriority(PRIO_PROCESS, (id_t)gettid(), 10);
    unsigned long long t0 = core_now_ns();
    core_status st = j->groom_path[0] ? app_groom_load_path(j->groom_path, j->label, j->verts, &l->g, &l->err)
                                      : app_groom_load_named(j->style, j->strands, j->verts, j->seed, &l->g, &l->err);
    l->code = PROTO_ERR_FAILED;
    l->field = j->groom_path[0] ? "file" : "style";
    if (st == CORE_OK && ((st = app_groom_check_size(&l->g, &l->err)) != CORE_OK ||
                          (st = app_budget_check(j->particles_per_s, j->min_rate, j->params.solver, l->g.g.nstrands,
                                                 l->g.g.nverts, &l->err)) != CORE_OK)) {
        l->code = PROTO_ERR_TOO_LARGE;
        app_groom_free(&l->g);
    }
    l->groom_ms = (double)(core_now_ns() - t0) / 1e6;
    if (st == CORE_OK && (j->mesh_path[0] || j->has_keep)) {
        l->field = "collider";
        core_mesh m = j->keep;
        memset(&j->keep, 0, sizeof j->keep);
        j->has_keep = false;
        unsigned long long t1 = core_now_ns();
        if (j->mesh_path[0]) st = groom_mesh_load_file(j->mesh_path, &m, &l->err);
        l->g.mesh_ms = (double)(core_now_ns() - t1) / 1e6;
        if (st == CORE_OK) st = app_groom_set_collider(&l->g, &m, j->mesh_label, &l->err);
        if (st != CORE_OK) app_groom_free(&l->g);
    }
    if (st == CORE_OK) {
        l->field = "";
        if ((st = make_sim(l)) != CORE_OK) app_groom_free(&l->g);
    }
    l->st = st;
    l->total_ms = (double)(core_now_ns() - t0) / 1e6;
    atomic_store(&l->done, true);
    app_mailbox_wake(l->wake);
    return NULL;
}

core_status app_loader_start(app_loader *l, app_mailbox *wake, core_err *err)
{
    l->wake = wake;
    atomic_store(&l->done, false);
    if (pthread_create(&l->thread, NULL, loader_main, l) != 0) {
        core_mesh_free(&l->job.keep);
        return core_fail(err, CORE_EBACKEND, "cannot start the groom loader thread");
    }
    l->running = true;
    return CORE_OK;
}

bool app_loader_collect(app_loader *l)
{
    if (!l->running || !atomic_load(&l->done)) return false;
    pthread_join(l->thread, NULL);
    l->running = false;
    return true;
}

void app_loader_clear(app_loader *l)
{
    sim_destroy(&l->sim);
    free(l->xyz);
    l->xyz = NULL;
    app_groom_free(&l->g);
    core_mesh_free(&l->job.keep);
}

void app_loader_join(app_loader *l)
{
    if (!l->running) return;
    pthread_join(l->thread, NULL);
    l->running = false;
    app_loader_clear(l);
}
