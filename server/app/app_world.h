/* app: the sim thread's world: the simulation and its live groom, parameters and head
 * animation, the run state (paused, steps owed), the streams and clients, the groom loader and
 * the pacing windows. The sim thread owns all of it; it borrows the shared pieces (outbox,
 * stats board, mailbox, asset list, parser tables) that app_run.c owns. */
#ifndef APP_WORLD_H
#define APP_WORLD_H

#include <stdatomic.h>
#include <stdbool.h>

#include "app.h"
#include "app_anim.h"
#include "app_assets.h"
#include "app_budget.h"
#include "app_clients.h"
#include "app_groom.h"
#include "app_loader.h"
#include "app_mailbox.h"
#include "app_outbox.h"
#include "app_record.h"
#include "app_replay.h"
#include "app_stats.h"
#include "app_stream.h"

/* Wall-clock measuring windows of the sim thread: the stats window (1 s) and the log window. */
typedef struct app_pace {
    unsigned long long win_start_ns, log_start_ns;
    uint64_t win_steps, log_steps;
    double step_ms_acc, log_step_ms_acc, encode_ms_acc;
    uint64_t encode_rounds;
    double publish_acc;       /* simulated time since the last publish round */
    /* abandoning a step for a change (app_sim.c): when the step in progress began, how long the
     * last two whole ones took (steps with and without an SPH evaluation alternate), whether
     * this one was abandoned already, and the wall time thrown away by abandoned steps in the
     * current stats window, and whether the simulation is behind real time (no step is
     * abandoned then) */
    unsigned long long step_t0_ns, last_step_ns[2], abandoned_ns;
    bool abandoned;
    bool behind;              /* the step in progress began over half a step after its slot */
} app_pace;

typedef struct app_world {
    const app_desc *d;        /* the daemon's settings (defaults applied) */

    /* the simulation */
    sim sim;
    sim_backend_kind backend; /* the backend the first simulation resolved to: later ones use it */
    app_budget budget;        /* what that backend steps per solver (app_budget); 0 = no groom budget */
    sim_params params;
    app_groom groom;
    float *xyz;               /* positions of the current groom, strand-major */
    float *mesh_xyz;          /* the simulated hair mesh's vertices for hair mesh streams
                                 (mesh_cap floats, grown when read) */
    size_t mesh_cap;
    app_anim anim;            /* head motion: client base pose, preset, blend */
    core_xform head;          /* the head transform the positions belong to: the last one handed
                                 to the simulation (app_world_set_head), rotation normalised */

    /* run state */
    bool paused;
    int32_t step_budget;      /* steps left while paused */
    bool dirty;               /* publish the current positions even when not stepping */
    core_status fatal;        /* a sim-thread failure that stops the daemon */
    core_err fatal_err;

    app_streams streams;
    app_clients clients;
    app_loader loader;        /* the set_groom being loaded */
    app_pace pace;
    uint64_t step_no;         /* steps since the daemon started: the clock of --record and --replay */

    /* borrowed from app_run.c */
    app_outbox *out;
    app_stats_board *board;
    app_mailbox *mb;
    atomic_uint *grooms_pending;  /* set_groom requests queued or being carried out (at most 1) */
    const app_assets *assets;
    const core_param_info *ptable;
    size_t nparams;
    const char *const *styles;    /* app_groom_styles: set_groom's style names */
    app_record *rec;              /* --record; NULL = off */
    app_replay *replay;           /* --replay; NULL = off */

    /* thread control */
    atomic_bool quit;         /* ask the sim thread to stop */
    atomic_bool done;         /* the sim thread has finished (steps reached or failure) */
} app_world;

/* Puts the simulation back to its rest pose; its own counters restart at 0, so the baseline the
 * daemon's NaN total counts from does too (the daemon's totals go on). Sim thread. */
void app_world_reset(app_world *w);
/* The run state for state messages and the hello. Sim thread. */
proto_state app_world_state(const app_world *w);
/* Hands the simulation the head transform of its next step (the pose after a reset until then)
 * and keeps it as w->head. Sim thread. */
void app_world_set_head(app_world *w, core_xform head);
/* The snapshot the current positions belong to (time, step, head), as frames carry it. Sim
 * thread. */
codec_sim_info app_world_snapshot(const app_world *w);

#endif
