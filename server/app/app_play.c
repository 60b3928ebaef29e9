/* app: record and replay on the sim thread (the file formats are app_rec's). */
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "app_cmd.h"
#include "app_play.h"

void app_play_record(app_world *w, const proto_msg *m)
{
    if (w->rec) app_record_input(w->rec, w->step_no, m);
}

bool app_play_refuse(app_world *w, uint32_t client, const proto_msg *m)
{
    if (!w->replay || !w->replay->active || client == APP_REPLAY_CLIENT) return false;
    switch (m->type) {
    case PROTO_SET_PARAMS: case PROTO_MOTION: case PROTO_ANIMATE: case PROTO_RESET: case PROTO_PAUSE: case PROTO_RESUME:
    case PROTO_STEP: case PROTO_SET_GROOM: break;
    default: return false;
    }
    if (m->type == PROTO_SET_GROOM) atomic_fetch_sub(w->grooms_pending, 1);
    char msg[160];
    snprintf(msg, sizeof msg, "a recording is being replayed (until step %llu of %llu); changes are taken when it ends",
             (unsigned long long)w->step_no, (unsigned long long)w->replay->end_step);
    app_reply_fail(w->out, client, &m->id, PROTO_ERR_BAD_STATE, "", msg);
    return true;
}

/* A replayed set_groom: started, and waited for, so that it is swapped in at its step. */
static void replay_groom(app_world *w, app_cmd *c)
{
    atomic_fetch_add(w->grooms_pending, 1);
    app_cmd_handle(w, c);
    struct timespec ms = { 0, 1000000 };
    while (w->loader.running) {
        app_cmd_groom_poll(w);
        if (w->loader.running) nanosleep(&ms, NULL);
    }
}

static void end_replay(app_world *w)
{
    app_replay *r = w->replay;
    r->active = false;
    char checked[96];
    if (r->digests == w->step_no)
        snprintf(checked, sizeof checked, "every step's positions (%llu) equal to the recording's", (unsigned long long)r->digests);
    else
        snprintf(checked, sizeof checked, "%llu steps' positions checked (the recording has no digests of the others)",
                 (unsigned long long)r->digests);
    core_log(CORE_LOG_INFO, "replay", "%s: ended after %llu steps, %llu inputs; %s%s", r->path, (unsigned long long)w->step_no,
             (unsigned long long)r->inputs, checked, w->d->no_net ? "" : "; paused, live from here");
    if (w->d->no_net) {
        atomic_store(&w->quit, true);
        return;
    }
    w->paused = true;
    w->step_budget = 0;
    proto_state s = app_world_state(w);
    app_send(w->out, NET_ALL, proto_build_state(NULL, &s), APP_ANNOUNCE_STATE);
}

void app_play_inputs(app_world *w)
{
    app_replay *r = w->replay;
    if (!r || !r->active) return;
    const proto_msg *m;
    while ((m = app_replay_input(r, w->step_no))) {
        app_cmd c = { .kind = APP_CMD_MSG, .client = APP_REPLAY_CLIENT, .msg = *m };
        if (m->type == PROTO_SET_GROOM) replay_groom(w, &c);
        else app_cmd_handle(w, &c);
    }
    if (w->step_no >= r->end_step) end_replay(w);
}

core_status app_play_stepped(app_world *w)
{
    w->step_no++;
    bool record = w->rec && w->rec->digests, check = w->replay && w->replay->active && w->replay->start.backend == SIM_BACKEND_CPU;
    if (!record && !check) return CORE_OK;
    core_err err;
    if (sim_read_positions(&w->sim, w->xyz, &err) != CORE_OK) {
        w->fatal_err = err;
        return w->fatal = CORE_EBACKEND;
    }
    uint64_t d = app_rec_digest(w->xyz, (size_t)w->groom.g.nstrands * w->groom.g.nverts * 3);
    if (record) app_record_digest(w->rec, w->step_no, d);
    if (check && !app_replay_check(w->replay, w->step_no, d, &w->fatal_err)) return w->fatal = CORE_ESTATE;
    return CORE_OK;
}
