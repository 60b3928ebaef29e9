/* app: the sim thread: commands at step boundaries, real-time fixed steps, publishing, stats. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>

#include "app_cmd.h"
#include "app_play.h"
#include "app_sim.h"

#define NS 1000000000ull
/* Wall time abandoned steps may throw away per stats window (a tenth of it): a slider dragged
 * at the frame rate shows its first changes at once without taking the steps' rate below
 * real time. */
#define ABANDON_BUDGET_NS (NS / 10)
/* Steps the simulation may run ahead of real time to show commands at once (app_sim_main). */
#define APP_SIM_AHEAD 2

/* sim_set_cancel's poll, between the stages of a step: abandon it when a change is queued, the
 * step is in the first half of the longer of the last two (later, finishing it costs less than
 * starting again; steps with an SPH evaluation take about twice the others), it was not
 * abandoned already, the simulation keeps real time (behind it, the work thrown away would put
 * it further behind) and the window's budget allows. The change then waits for its own step
 * only. Sim thread. */
static bool abandon_for_change(void *ctx)
{
    app_world *w = ctx;
    app_pace *pc = &w->pace;
    if (pc->abandoned || pc->behind || !app_mailbox_change_waiting(w->mb)) return false;
    const unsigned long long spent = core_now_ns() - pc->step_t0_ns;
    const unsigned long long whole = pc->last_step_ns[0] > pc->last_step_ns[1] ? pc->last_step_ns[0] : pc->last_step_ns[1];
    if (2 * spent > whole || pc->abandoned_ns + spent > ABANDON_BUDGET_NS) return false;
    pc->abandoned = true;
    pc->abandoned_ns += spent;
    return true;
}

void app_sim_arm(app_world *w)
{
    /* a replay takes no changes from clients, and its steps must run as recorded */
    if (!w->replay) sim_set_cancel(&w->sim, abandon_for_change, w);
}

/* One step; CORE_ECANCELED when it was abandoned for a change (abandon_for_change): the head
 * motion is then as before it, and the caller takes the commands and steps again. */
static core_status step_once(app_world *w)
{
    const app_anim anim = w->anim;
    const core_xform head = w->head;
    app_anim_advance(&w->anim, w->params.dt);
    app_world_set_head(w, app_anim_pose(&w->anim));
    unsigned long long t0 = core_now_ns();
    w->pace.step_t0_ns = t0;
    core_status st = sim_step(&w->sim, &w->fatal_err);
    if (st == CORE_ECANCELED) {
        w->anim = anim;
        app_world_set_head(w, head);
        pthread_mutex_lock(&w->board->mu);
        w->board->s.steps_abandoned++;
        pthread_mutex_unlock(&w->board->mu);
        return st;
    }
    w->pace.abandoned = false;
    w->pace.last_step_ns[1] = w->pace.last_step_ns[0];
    w->pace.last_step_ns[0] = core_now_ns() - t0;
    double ms = (double)(core_now_ns() - t0) / 1e6;
    w->pace.step_ms_acc += ms;
    w->pace.log_step_ms_acc += ms;
    w->pace.win_steps++;
    w->pace.log_steps++;
    return st;
}

/* The simulated hair mesh's vertices when a due stream carries them, else (or when they cannot
 * be read: logged) NULL. */
static const float *read_mesh(app_world *w)
{
    if (!app_streams_mesh_due(&w->streams)) return NULL;
    size_t n = 3u * (size_t)w->streams.ncols * w->streams.nlayers;
    if (n > w->mesh_cap) {
        float *p = realloc(w->mesh_xyz, n * sizeof *p);
        if (!p) {
            core_log(CORE_LOG_WARN, "sim", "out of memory for the hair mesh's %zu floats", n);
            return NULL;
        }
        w->mesh_xyz = p;
        w->mesh_cap = n;
    }
    core_err err;
    if (sim_read_hairmesh(&w->sim, w->mesh_xyz, &err) != CORE_OK) {
        core_log(CORE_LOG_WARN, "sim", "hair mesh not read for streaming: %s", err.msg);
        return NULL;
    }
    return w->mesh_xyz;
}

/* Encodes and publishes the positions to the due streams; counts for the stats. */
static void publish(app_world *w)
{
    unsigned long long t0 = core_now_ns();
    const codec_sim_info snap = app_world_snapshot(w);
    app_publish_result r = app_streams_publish(&w->streams, w->xyz, read_mesh(w), &snap);
    for (uint32_t m = r.began_failing; m; m &= m - 1) /* usually none: no loop per frame */
        app_cmd_tell_failure(w, __builtin_ctz(m), NET_ALL);
    if (!w->out->net) return;
    pthread_mutex_lock(&w->board->mu);
    w->board->s.frames_encoded += r.frames;
    w->board->s.encode_bytes += r.bytes;
    pthread_mutex_unlock(&w->board->mu);
    w->pace.encode_ms_acc += (double)(core_now_ns() - t0) / 1e6;
    w->pace.encode_rounds++;
}

/* Publishes when the stream rate says so (a round every step at the default 60 Hz; a stream
 * of decimation k takes every k-th round), reading the positions from the backend only when
 * some stream takes a frame. */
static void maybe_publish(app_world *w, bool stepped)
{
    bool tick = false;
    if (stepped) {
        double period = 1.0 / w->d->rate;
        w->pace.publish_acc += w->params.dt;
        if (w->pace.publish_acc >= period - 1e-9) {
            w->pace.publish_acc -= period;
            if (w->pace.publish_acc > period) w->pace.publish_acc = 0.0;
            tick = true;
        }
    }
    if (!tick && !w->dirty) return;
    if (!app_streams_due(&w->streams, tick, w->dirty)) { /* nobody to send to: the positions are not even read */
        w->dirty = false;
        return;
    }
    core_err err;
    if (sim_read_positions(&w->sim, w->xyz, &err) != CORE_OK) {
        core_log(CORE_LOG_WARN, "sim", "positions not read for streaming: %s", err.msg);
        return;
    }
    w->dirty = false;
    publish(w);
}

/* Applies every queued command; true when there was one. */
static bool take_commands(app_world *w)
{
    app_play_inputs(w); /* a replay's inputs of this step boundary, before any client's */
    app_cmd c;
    bool took = false;
    while (app_mailbox_take(w->mb, &c)) {
        app_cmd_handle(w, &c);
        took = true;
    }
    /* a set_groom whose loads finished: its rest pose is shown at once, not after its first
     * step (which rebuilds every neighbour list: the longest step of a groom's life) */
    if (app_cmd_groom_poll(w)) maybe_publish(w, false);
    return took;
}

/* Once a second: stats for clients and /metrics; every APP_LOG_INTERVAL_S a log line. */
static void update_stats(app_world *w, unsigned long long now)
{
    app_pace *pc = &w->pace;
    if (now - pc->win_start_ns < NS) return;
    double secs = (double)(now - pc->win_start_ns) / 1e9;
    sim_stats ss;
    sim_get_stats(&w->sim, &ss);
    pthread_mutex_lock(&w->board->mu);
    app_stats *b = &w->board->s;
    b->steps = ss.steps;
    b->sim_time = ss.sim_time;
    b->steps_per_s = (double)pc->win_steps / secs;
    b->step_ms = pc->win_steps ? pc->step_ms_acc / (double)pc->win_steps : 0.0;
    b->encode_ms = pc->encode_rounds ? pc->encode_ms_acc / (double)pc->encode_rounds : 0.0;
    b->clients = (uint32_t)w->clients.n;
    app_stats s = *b;
    pthread_mutex_unlock(&w->board->mu);
    proto_stats ps = { s.steps_per_s, s.step_ms, s.encode_ms, s.clients, s.sim_time, s.steps, s.nan_resets };
    if (w->clients.n) app_send(w->out, NET_ALL, proto_build_stats(&ps), NET_TEXT_DROPPABLE);
    pc->win_start_ns = now;
    pc->win_steps = 0;
    pc->step_ms_acc = pc->encode_ms_acc = 0.0;
    pc->encode_rounds = 0;
    pc->abandoned_ns = 0;

    double log_secs = (double)(now - pc->log_start_ns) / 1e9;
    if (log_secs >= APP_LOG_INTERVAL_S) {
        double sps = (double)pc->log_steps / log_secs;
        core_log(CORE_LOG_INFO, "sim", "%.1f steps/s (real time %.0f), step %.2f ms, encode %.2f ms, %zu clients%s",
                 sps, 1.0 / w->params.dt, pc->log_steps ? pc->log_step_ms_acc / (double)pc->log_steps : 0.0, s.encode_ms,
                 w->clients.n, w->paused ? ", paused" : "");
        pc->log_start_ns = now;
        pc->log_steps = 0;
        pc->log_step_ms_acc = 0.0;
    }
}

/* After a step: the /metrics counters, exact between stats windows. */
static void count_step(app_world *w)
{
    sim_stats ss;
    sim_get_stats(&w->sim, &ss);
    pthread_mutex_lock(&w->board->mu);
    app_stats *b = &w->board->s;
    b->steps_run++;
    b->nan_resets_run += ss.nan_resets - b->nan_resets; /* zeroed with the sim's */
    b->nan_resets = ss.nan_resets;
    b->steps = ss.steps;
    b->sim_time = ss.sim_time;
    pthread_mutex_unlock(&w->board->mu);
}

void *app_sim_main(void *arg)
{
    app_world *w = arg;
    prctl(PR_SET_NAME, "sc-sim");
    unsigned long long next = core_now_ns();
    w->pace.win_start_ns = w->pace.log_start_ns = next;
    uint64_t total = 0;
    app_sim_arm(w);
    /* A command that comes while the thread waits for the next step's time is shown at once:
     * the step runs then, ahead of the clock, and the next slot that finds the simulation ahead
     * and nothing new to show is skipped. At most APP_SIM_AHEAD steps ahead, so the simulation
     * keeps real time on average; a command taken when it is that far ahead runs at the next
     * slot (never skipped while a command waits to be shown). With abandoned steps
     * (abandon_for_change), a change waits for about its own step only. */
    int ahead = 0;       /* steps taken ahead of their slots */
    bool pending = false; /* a command taken that no step has shown yet */
    while (!atomic_load(&w->quit)) {
        /* wait for the next step's wall-clock time, handling commands as they come */
        bool early = false;
        for (;;) {
            pending |= take_commands(w);
            unsigned long long now = core_now_ns();
            if (now >= next || atomic_load(&w->quit)) break;
            if (pending && ahead < APP_SIM_AHEAD && (!w->paused || w->step_budget > 0)) {
                early = true;
                break;
            }
            if (w->dirty) maybe_publish(w, false);
            app_mailbox_wait(w->mb, next);
        }
        if (atomic_load(&w->quit)) break;
        if (!early && ahead > 0 && !pending) { /* this slot's step already ran */
            ahead--;
            next += (unsigned long long)(w->params.dt * 1e9);
            continue;
        }
        bool run = !w->paused || w->step_budget > 0;
        if (run) {
            w->pace.behind = core_now_ns() > next + (unsigned long long)(w->params.dt * 0.5e9);
            core_status st = step_once(w);
            if (st == CORE_ECANCELED) continue; /* the change is taken above, then this step again */
            if ((w->fatal = st) != CORE_OK) {
                core_log(CORE_LOG_ERROR, "sim", "step failed: %s", w->fatal_err.msg);
                break;
            }
            if (app_play_stepped(w) != CORE_OK) {
                core_log(CORE_LOG_ERROR, "replay", "%s", w->fatal_err.msg);
                break;
            }
            total++;
            count_step(w);
            if (w->paused && --w->step_budget == 0) {
                proto_state s = app_world_state(w);
                app_send(w->out, NET_ALL, proto_build_state(NULL, &s), APP_ANNOUNCE_STATE);
            }
        }
        pending = false;
        maybe_publish(w, run);
        unsigned long long now = core_now_ns();
        update_stats(w, now);
        if (w->d->steps && total >= w->d->steps) break;
        if (early) {
            ahead++;
            continue;
        }
        next += (unsigned long long)(w->params.dt * 1e9);
        /* more than a quarter second behind: give up catching up (log shows the deficit) */
        if (now > next + NS / 4) next = now;
    }
    atomic_store(&w->done, true);
    return NULL;
}
