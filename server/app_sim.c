/* app: the sim thread: commands at step boundaries, real-time fixed steps, publishing, stats. */
#include <stdio.h>
#include <string.h>
#include <sys/prctl.h>

#include "app_internal.h"

#define NS 1000000000ull

/* Applies every queued command. */
static void take_commands(app *a)
{
    app_cmd c;
    while (app_mailbox_take(&a->mb, &c)) app_handle(a, &c);
    app_regroom_poll(a); /* a set_groom whose loads finished */
}

static core_status step_once(app *a)
{
    app_anim_advance(&a->anim, a->params.dt);
    sim_set_motion(&a->sim, app_anim_pose(&a->anim));
    unsigned long long t0 = core_now_ns();
    core_status st = sim_step(&a->sim, &a->fatal_err);
    double ms = (double)(core_now_ns() - t0) / 1e6;
    a->step_ms_acc += ms;
    a->log_step_ms_acc += ms;
    a->win_steps++;
    a->log_steps++;
    return st;
}

/* Publishes when the stream rate says so (a round every step at the default 60 Hz; a stream
 * of decimation k takes every k-th round), reading the positions from the backend only when
 * some stream takes a frame. */
static void maybe_publish(app *a, bool stepped)
{
    bool tick = false;
    if (stepped) {
        double period = 1.0 / a->d.rate;
        a->publish_acc += a->params.dt;
        if (a->publish_acc >= period - 1e-9) {
            a->publish_acc -= period;
            if (a->publish_acc > period) a->publish_acc = 0.0;
            tick = true;
        }
    }
    if (!tick && !a->dirty) return;
    if (!app_tiers_due(a, tick, a->dirty)) { /* nobody to send to: the positions are not even read */
        a->dirty = false;
        return;
    }
    core_err err;
    if (sim_read_positions(&a->sim, a->xyz, &err) != CORE_OK) {
        core_log(CORE_LOG_WARN, "sim", "positions not read for streaming: %s", err.msg);
        return;
    }
    a->dirty = false;
    app_publish(a);
}

/* Once a second: stats for clients and /metrics; every APP_LOG_INTERVAL_S a log line. */
static void update_stats(app *a, unsigned long long now)
{
    if (now - a->win_start_ns < NS) return;
    double secs = (double)(now - a->win_start_ns) / 1e9;
    sim_stats ss;
    sim_get_stats(&a->sim, &ss);
    pthread_mutex_lock(&a->stats_mu);
    a->stats.steps = ss.steps;
    a->stats.sim_time = ss.sim_time;
    a->stats.steps_per_s = (double)a->win_steps / secs;
    a->stats.step_ms = a->win_steps ? a->step_ms_acc / (double)a->win_steps : 0.0;
    a->stats.encode_ms = a->encode_rounds ? a->encode_ms_acc / (double)a->encode_rounds : 0.0;
    a->stats.clients = (uint32_t)a->nclients;
    app_stats s = a->stats;
    pthread_mutex_unlock(&a->stats_mu);
    proto_stats ps = { s.steps_per_s, s.step_ms, s.encode_ms, s.clients, s.sim_time, s.steps, s.nan_resets };
    if (a->nclients) app_send(a, NET_ALL, proto_build_stats(&ps), NET_TEXT_DROPPABLE);
    a->win_start_ns = now;
    a->win_steps = 0;
    a->step_ms_acc = a->encode_ms_acc = 0.0;
    a->encode_rounds = 0;

    double log_secs = (double)(now - a->log_start_ns) / 1e9;
    if (log_secs >= APP_LOG_INTERVAL_S) {
        double sps = (double)a->log_steps / log_secs;
        core_log(CORE_LOG_INFO, "sim", "%.1f steps/s (real time %.0f), step %.2f ms, encode %.2f ms, %zu clients%s",
                 sps, 1.0 / a->params.dt, a->log_steps ? a->log_step_ms_acc / (double)a->log_steps : 0.0, s.encode_ms,
                 a->nclients, a->paused ? ", paused" : "");
        a->log_start_ns = now;
        a->log_steps = 0;
        a->log_step_ms_acc = 0.0;
    }
}

void *app_sim_main(void *arg)
{
    app *a = arg;
    prctl(PR_SET_NAME, "sc-sim");
    unsigned long long next = core_now_ns();
    a->win_start_ns = a->log_start_ns = next;
    uint64_t total = 0;
    while (!atomic_load(&a->quit)) {
        /* wait for the next step's wall-clock time, handling commands as they come */
        for (;;) {
            take_commands(a);
            unsigned long long now = core_now_ns();
            if (now >= next || atomic_load(&a->quit)) break;
            if (a->dirty) maybe_publish(a, false);
            app_mailbox_wait(&a->mb, next);
        }
        if (atomic_load(&a->quit)) break;
        bool run = !a->paused || a->step_budget > 0;
        if (run) {
            if ((a->fatal = step_once(a)) != CORE_OK) {
                core_log(CORE_LOG_ERROR, "sim", "step failed: %s", a->fatal_err.msg);
                break;
            }
            total++;
            sim_stats ss;
            sim_get_stats(&a->sim, &ss);
            pthread_mutex_lock(&a->stats_mu); /* /metrics counters stay exact between stats windows */
            a->stats.steps_run++;
            a->stats.nan_resets_run += ss.nan_resets - a->stats.nan_resets; /* zeroed with the sim's */
            a->stats.nan_resets = ss.nan_resets;
            a->stats.steps = ss.steps;
            a->stats.sim_time = ss.sim_time;
            pthread_mutex_unlock(&a->stats_mu);
            if (a->paused && --a->step_budget == 0) {
                proto_state s = app_state(a);
                app_send(a, NET_ALL, proto_build_state(NULL, &s), 0);
            }
        }
        maybe_publish(a, run);
        unsigned long long now = core_now_ns();
        update_stats(a, now);
        if (a->d.steps && total >= a->d.steps) break;
        next += (unsigned long long)(a->params.dt * 1e9);
        /* more than a quarter second behind: give up catching up (log shows the deficit) */
        if (now > next + NS / 4) next = now;
    }
    atomic_store(&a->sim_done, true);
    return NULL;
}
