/* app: the groom loader thread: one set_groom's work (the groom, its collision mesh and SDF:
 * seconds for a large mesh; then the new simulation: buffers, thread pool or Vulkan pipelines)
 * runs off the sim thread, which fills the job, starts it and swaps the result in at a step
 * boundary. One load at a time. The loader owns its job and result until collected. */
#ifndef APP_LOADER_H
#define APP_LOADER_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>

#include "app_groom.h"
#include "app_mailbox.h"
#include "sim/sim.h"

/* What to load (filled on the sim thread before app_loader_start). */
typedef struct app_load_job {
    char groom_path[2048];    /* a groom file, or "" for the procedural style */
    const char *label;        /* the groom file's name (shown as file:<label>; outlives the load) */
    const char *style;
    uint32_t strands, verts;
    uint64_t seed;
    char mesh_path[2048];     /* a collision mesh file, or "" */
    bool has_keep;            /* keep: a copy of the live groom's mesh */
    core_mesh keep;
    char mesh_label[PROTO_MAX_NAME + 1];
    sim_desc sim;             /* the simulation to create (a resolved backend: no AUTO trial) */
    sim_params params;        /* its parameters (the sim thread applies the current ones at the swap);
                                 solver hairmesh becomes dftl on a groom without a hair mesh */
    double particles_per_s, min_rate; /* the groom budget (app_budget_check); 0 = none */
} app_load_job;

typedef struct app_loader {
    pthread_t thread;
    bool running;             /* sim thread: started and not yet collected */
    atomic_bool done;         /* loader: the result is ready */
    app_mailbox *wake;        /* woken when the result is ready */
    uint32_t client;          /* the request being served (for the replies) */
    proto_msg msg;
    app_load_job job;
    /* the result */
    app_groom g;
    sim sim;                  /* created for g (zeroed on failure) */
    float *xyz;               /* positions buffer for g */
    core_status st;
    proto_code code;          /* on failure: the error code and field to reply with */
    const char *field;
    core_err err;
    double groom_ms, sim_ms, total_ms;
} app_loader;

/* Starts the load of l->job on a new thread (l->job, client and msg filled, not running);
 * wake is posted a wake-up when it is done. CORE_EBACKEND when the thread cannot start (the
 * job's kept mesh is freed). Sim thread. */
core_status app_loader_start(app_loader *l, app_mailbox *wake, core_err *err);
/* True when a started load has finished: the thread is joined and the result is in l (the
 * caller takes l->g or leaves it to app_loader_clear). Sim thread. */
bool app_loader_collect(app_loader *l);
/* Frees what a collected load left in l. Sim thread. */
void app_loader_clear(app_loader *l);
/* Waits for a running load and drops its result (shutdown, after the sim thread ended). */
void app_loader_join(app_loader *l);

#endif
