/* app: wires groom -> sim -> codec -> net and back; owns the threads and the signal-driven shutdown. */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <time.h>

#include "app_internal.h"
#include "groom/groom.h"

_Static_assert(APP_PORT_ANY == NET_PORT_ANY, "app and net agree on the free-port value");

static void defaults(app_desc *d)
{
    if (!d->groom) d->groom = "straight";
    if (d->rate <= 0.0) d->rate = APP_DEFAULT_RATE;
    if (d->max_error <= 0.0) d->max_error = APP_DEFAULT_MAX_ERROR;
    if (d->keyframe_interval <= 0) d->keyframe_interval = APP_DEFAULT_KEY_INTERVAL;
}

/* The --collider mesh into the loaded groom (its SDF covers what that groom's hair reaches). */
static core_status load_initial_collider(app *a, core_err *err)
{
    if (!a->d.collider) return CORE_OK;
    core_mesh m;
    unsigned long long t0 = core_now_ns();
    core_status st = groom_mesh_load_file(a->d.collider, &m, err);
    if (st != CORE_OK) return st;
    double load_ms = (double)(core_now_ns() - t0) / 1e6;
    const char *base = strrchr(a->d.collider, '/');
    if ((st = app_groom_set_collider(&a->groom, &m, base ? base + 1 : a->d.collider, err)) != CORE_OK) return st;
    a->groom.mesh_ms = load_ms;
    const core_sdf *s = a->groom.g.sdf;
    core_log(CORE_LOG_INFO, "app", "collider %s: %u vertices, %u triangles (%.0f ms); grid %ux%ux%u of %.4g m (%.0f ms)",
             a->groom.collider, a->groom.g.mesh->nverts, a->groom.g.mesh->ntris, load_ms, s ? s->dims[0] : 0,
             s ? s->dims[1] : 0, s ? s->dims[2] : 0, s ? s->cell : 0.0f, a->groom.sdf_ms);
    return CORE_OK;
}

static core_status load_initial_groom(app *a, core_err *err)
{
    groom_style style;
    core_status st;
    unsigned long long t0 = core_now_ns();
    if (groom_style_parse(a->d.groom, &style, NULL) == CORE_OK) {
        st = app_groom_load_style(a, a->d.groom, a->d.strands, a->d.verts, a->d.seed, &a->groom, err);
    } else {
        const char *base = strrchr(a->d.groom, '/');
        st = app_groom_load_path(a, a->d.groom, base ? base + 1 : a->d.groom, a->d.verts, &a->groom, err);
        if (st == CORE_OK && (st = app_groom_check_size(&a->groom, err)) != CORE_OK) app_groom_free(&a->groom);
    }
    if (st != CORE_OK) return st;
    core_log(CORE_LOG_INFO, "app", "groom %s loaded in %.0f ms", a->groom.source, (double)(core_now_ns() - t0) / 1e6);
    return load_initial_collider(a, err);
}

static core_status setup(app *a, core_err *err)
{
    a->ptable = sim_param_table(&a->nparams);
    if (a->nparams > PROTO_MAX_PARAMS)
        return core_fail(err, CORE_EINVAL, "the parameter table has %zu entries; proto serves at most %d", a->nparams,
                         PROTO_MAX_PARAMS);
    for (int i = 0; i < 3; i++) a->styles[i] = groom_style_name((groom_style)i);
    a->parser = (proto_parser){ a->ptable, a->nparams, app_preset_names, APP_PRESET_COUNT, a->styles, 3 };
    sim_params_default(&a->params);
    app_anim_init(&a->anim);
    pthread_mutex_init(&a->stats_mu, NULL);
    core_status st = app_mailbox_init(&a->mb, err);
    if (st != CORE_OK) return st;
    app_list_assets(a);
    if ((st = load_initial_groom(a, err)) != CORE_OK) return st;
    sim_desc sd = { .backend = a->d.backend, .threads = a->d.threads, .device = a->d.device };
    if ((st = sim_create(&a->sim, &sd, &a->groom.g, &a->params, err)) != CORE_OK) return st;
    size_t n = (size_t)a->groom.g.nstrands * a->groom.g.nverts * 3;
    a->xyz = malloc(n * sizeof *a->xyz);
    if (!a->xyz) return core_fail(err, CORE_ENOMEM, "out of memory for %zu positions", n / 3);
    sim_set_motion(&a->sim, app_anim_pose(&a->anim));
    if ((st = sim_read_positions(&a->sim, a->xyz, err)) != CORE_OK) return st;
    core_log(CORE_LOG_INFO, "app", "groom %s: %u strands x %u vertices, %u colliders; backend %s", a->groom.source,
             a->groom.g.nstrands, a->groom.g.nverts, a->groom.g.ncolliders, a->sim.vt->name);
    if (a->d.no_net) return CORE_OK;
    net_desc nd = {
        .listen = a->d.listen, .port = a->d.port, .web_dir = a->d.web_dir, .subprotocol = PROTO_SUBPROTOCOL,
        .max_message = PROTO_MAX_MESSAGE, .sndbuf = a->d.client_buffer,
        .ping_s = a->d.ping_interval, .hangup_s = a->d.ping_timeout, .blobs = { APP_MESH_PATH },
        .cb = { a, app_on_open, app_on_text, app_on_close, app_metrics },
    };
    if ((st = net_create(&a->net, &nd, err)) != CORE_OK) return st;
    app_publish_mesh(a);
    return CORE_OK;
}

static void teardown(app *a)
{
    net_destroy(a->net);
    a->net = NULL;
    app_tiers_free(a);
    sim_destroy(&a->sim);
    app_groom_free(&a->groom);
    free(a->xyz);
    free(a->clients);
    app_free_assets(a);
    app_mailbox_free(&a->mb);
    pthread_mutex_destroy(&a->stats_mu);
}

static void *net_main(void *arg)
{
    prctl(PR_SET_NAME, "sc-net"); /* thread names let tools (strandbench fanout) split CPU time */
    net_run(arg);
    return NULL;
}

/* Waits for SIGINT/SIGTERM (blocked, taken with sigtimedwait) or the sim thread's end. */
static void wait_for_stop(app *a, const sigset_t *set)
{
    struct timespec tick = { 0, 50 * 1000 * 1000 };
    while (!atomic_load(&a->sim_done)) {
        int sig = sigtimedwait(set, NULL, &tick);
        if (sig == SIGINT || sig == SIGTERM) {
            core_log(CORE_LOG_INFO, "app", "%s: shutting down", sig == SIGINT ? "SIGINT" : "SIGTERM");
            return;
        }
        if (sig < 0 && errno != EAGAIN && errno != EINTR) return;
    }
}

core_status app_run(const app_desc *desc, core_err *err)
{
    sigset_t set, old;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, &old);
    signal(SIGPIPE, SIG_IGN);

    app *a = calloc(1, sizeof *a);
    if (!a) return core_fail(err, CORE_ENOMEM, "out of memory");
    a->d = *desc;
    defaults(&a->d);
    core_status st = setup(a, err);
    pthread_t sim_thread, net_thread;
    bool sim_started = false, net_started = false;
    if (st == CORE_OK && a->net) {
        const char *host = a->d.listen && *a->d.listen ? a->d.listen : "127.0.0.1";
        bool any = strcmp(host, "0.0.0.0") == 0 || strcmp(host, "*") == 0;
        bool v6 = strchr(host, ':') != NULL;
        printf("strandcastd: open http://%s%s%s:%d/  (WebSocket subprotocol %s%s)\n", v6 ? "[" : "", any ? "127.0.0.1" : host,
               v6 ? "]" : "", net_port(a->net), PROTO_SUBPROTOCOL, any ? "; listening on every interface" : "");
        fflush(stdout);
        if (pthread_create(&net_thread, NULL, net_main, a->net) != 0) st = core_fail(err, CORE_EBACKEND, "cannot start the net thread");
        else net_started = true;
    }
    if (st == CORE_OK) {
        if (pthread_create(&sim_thread, NULL, app_sim_main, a) != 0) st = core_fail(err, CORE_EBACKEND, "cannot start the sim thread");
        else sim_started = true;
    }
    if (st == CORE_OK) wait_for_stop(a, &set);
    atomic_store(&a->quit, true);
    if (sim_started) {
        app_mailbox_wake(&a->mb);
        pthread_join(sim_thread, NULL);
        if (a->fatal != CORE_OK) st = core_fail(err, a->fatal, "simulation stopped: %s", a->fatal_err.msg);
    }
    app_regroom_join(a); /* a groom load still running (the sim thread has stopped) */
    if (net_started) {
        net_stop(a->net);
        pthread_join(net_thread, NULL);
    }
    if (st == CORE_OK) {
        sim_stats ss;
        sim_get_stats(&a->sim, &ss);
        core_log(CORE_LOG_INFO, "app", "stopped after %llu steps (%.2f s simulated)", (unsigned long long)ss.steps, ss.sim_time);
    }
    teardown(a);
    free(a);
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    return st;
}
