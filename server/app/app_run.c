/* app: app_run: wires groom -> sim -> codec -> net and back; owns the threads and the signal-driven shutdown. */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "app_budget.h"
#include "app_nats.h"
#include "app_net.h"
#include "app_parser.h"
#include "app_process.h"
#include "app_relay.h"
#include "app_sim.h"
#include "codec/codec.h"
#include "groom/groom.h"

/* The daemon: the settings, the pieces shared between threads, and the sim thread's world. */
typedef struct app {
    app_desc d;
    net *net;
    app_outbox out;           /* net thread and sim thread */
    app_mailbox mb;           /* net thread -> sim thread */
    app_stats_board board;    /* sim thread -> net thread */
    atomic_uint grooms_pending;
    proto_parser parser;      /* read-only after set-up */
    app_assets assets;        /* read-only after set-up */
    app_gate gate;            /* the net callbacks' view */
    app_world w;              /* the sim thread's */
    app_record rec;           /* --record (the sim thread appends, its own thread writes) */
    app_replay replay;        /* --replay (read-only but for the sim thread's cursor) */
    app_nats bus;             /* --nats: the simulation node's bridge */
} app;

int app_default_max_clients(void)
{
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    long n = APP_CLIENTS_PER_CORE * (cores > 1 ? cores : 1);
    return (int)(n < APP_MAX_CLIENTS ? n : APP_MAX_CLIENTS);
}

static void defaults(app_desc *d)
{
    if (!d->groom) d->groom = "straight";
    if (!d->room) d->room = PROTO_DEFAULT_ROOM;
    if (d->rate <= 0.0) d->rate = APP_DEFAULT_RATE;
    if (d->max_error <= 0.0) d->max_error = CODEC_DEFAULT_MAX_ERROR;
    if (d->keyframe_interval <= 0) d->keyframe_interval = (int)CODEC_DEFAULT_KEY_INTERVAL;
    if (d->max_clients <= 0) d->max_clients = app_default_max_clients();
    if (d->min_step_rate == 0.0) d->min_step_rate = APP_MIN_STEP_RATE;
}

/* The --collider mesh into the loaded groom (its SDF covers what that groom's hair reaches). */
static core_status load_initial_collider(const app_desc *d, app_groom *g, core_err *err)
{
    if (!d->collider) return CORE_OK;
    core_mesh m;
    unsigned long long t0 = core_now_ns();
    core_status st = groom_mesh_load_file(d->collider, &m, err);
    if (st != CORE_OK) return st;
    double load_ms = (double)(core_now_ns() - t0) / 1e6;
    const char *base = strrchr(d->collider, '/');
    if ((st = app_groom_set_collider(g, &m, base ? base + 1 : d->collider, err)) != CORE_OK) return st;
    g->mesh_ms = load_ms;
    const core_sdf *s = g->g.sdf;
    core_log(CORE_LOG_INFO, "app", "collider %s: %u vertices, %u triangles (%.0f ms); grid %ux%ux%u of %.4g m (%.0f ms)",
             g->collider, g->g.mesh->nverts, g->g.mesh->ntris, load_ms, s ? s->dims[0] : 0, s ? s->dims[1] : 0,
             s ? s->dims[2] : 0, s ? s->cell : 0.0f, g->sdf_ms);
    return CORE_OK;
}

static core_status load_initial_groom(const app_desc *d, app_groom *g, core_err *err)
{
    groom_style style;
    core_status st;
    unsigned long long t0 = core_now_ns();
    if (groom_style_parse(d->groom, &style, NULL) == CORE_OK) {
        st = app_groom_load_style(d->groom, d->strands, d->verts, d->seed, g, err);
    } else if (strncmp(d->groom, "hairmesh:", 9) == 0) {
        st = app_groom_load_hairmesh(d->groom + 9, d->strands, d->verts, g, err);
    } else {
        const char *base = strrchr(d->groom, '/');
        st = app_groom_load_path(d->groom, base ? base + 1 : d->groom, d->verts, g, err);
        if (st == CORE_OK && (st = app_groom_check_size(g, err)) != CORE_OK) app_groom_free(g);
    }
    if (st != CORE_OK) return st;
    core_log(CORE_LOG_INFO, "app", "groom %s loaded in %.0f ms", g->source, (double)(core_now_ns() - t0) / 1e6);
    return load_initial_collider(d, g, err);
}

/* Measures what the chosen backend steps (unless the budget is off) and refuses a start-up
 * groom over it. */
static core_status check_budget(const app *a, app_world *w, core_err *err)
{
    if (a->d.min_step_rate < 0.0) return CORE_OK;
    sim_desc sd = { .backend = w->backend, .threads = a->d.threads, .device = a->d.device };
    unsigned long long t0 = core_now_ns();
    core_status st = app_budget_measure(&sd, &w->budget, err);
    if (st != CORE_OK) return st;
    core_log(CORE_LOG_INFO, "app", "groom budget: dftl %.3g, pbd %.3g particles/s here (%.0f ms to measure); grooms of up to "
             "%.0f (dftl) and %.0f (pbd) particles step at %.0f steps/s", w->budget.dftl, w->budget.pbd,
             (double)(core_now_ns() - t0) / 1e6, w->budget.dftl / a->d.min_step_rate, w->budget.pbd / a->d.min_step_rate,
             a->d.min_step_rate);
    core_err why;
    if ((st = app_budget_check(app_budget_rate(&w->budget, w->params.solver), a->d.min_step_rate, w->params.solver,
                               w->groom.g.nstrands, w->groom.g.nverts, &why)) != CORE_OK)
        return core_fail(err, st, "--groom %s: %s (or lower --min-step-rate)", w->groom.source, why.msg);
    return CORE_OK;
}

/* The sim thread's world on the loaded groom (its pieces shared with the net thread are a's). */
static core_status setup_world(app *a, const core_param_info *ptable, size_t nparams, core_err *err)
{
    app_world *w = &a->w;
    w->d = &a->d;
    w->out = &a->out;
    w->board = &a->board;
    w->mb = &a->mb;
    w->grooms_pending = &a->grooms_pending;
    w->assets = &a->assets;
    w->ptable = ptable;
    w->nparams = nparams;
    w->styles = app_groom_styles;
    sim_params_default(&w->params);
    w->params.solver = a->d.solver;
    if (a->d.replay) w->params = a->replay.start.params;
    app_anim_init(&w->anim);
    core_status st = load_initial_groom(&a->d, &w->groom, err);
    if (st != CORE_OK) return st;
    sim_desc sd = { .backend = a->d.backend, .threads = a->d.threads, .device = a->d.device };
    if ((st = sim_create(&w->sim, &sd, &w->groom.g, &w->params, err)) != CORE_OK) return st;
    w->backend = sim_backend(&w->sim); /* groom changes create this kind without a new trial */
    if ((st = check_budget(a, w, err)) != CORE_OK) return st;
    size_t n = (size_t)w->groom.g.nstrands * w->groom.g.nverts * 3;
    w->xyz = malloc(n * sizeof *w->xyz);
    if (!w->xyz) return core_fail(err, CORE_ENOMEM, "out of memory for %zu positions", n / 3);
    app_world_set_head(w, app_anim_pose(&w->anim));
    if ((st = sim_read_positions(&w->sim, w->xyz, err)) != CORE_OK) return st;
    core_log(CORE_LOG_INFO, "app", "groom %s: %u strands x %u vertices, %u colliders; backend %s", w->groom.source,
             w->groom.g.nstrands, w->groom.g.nverts, w->groom.g.ncolliders, w->sim.vt->name);
    return CORE_OK;
}

/* Reads the --replay file; its initial state replaces the settings it records. */
static core_status open_replay(app *a, core_err *err)
{
    core_status st = app_replay_open(&a->replay, a->d.replay, &a->parser, &a->assets, a->d.assets_dir, err);
    if (st != CORE_OK) return st;
    const app_rec_start *s = &a->replay.start;
    a->d.groom = s->groom;
    a->d.collider = s->collider[0] ? s->collider : NULL;
    a->d.strands = s->strands;
    a->d.verts = s->verts;
    a->d.seed = s->seed;
    a->d.backend = (sim_backend_kind)s->backend;
    a->d.threads = s->threads;
    a->d.min_step_rate = -1.0; /* its grooms were accepted once: a slower machine replays them all the same */
    a->w.replay = &a->replay;
    core_log(CORE_LOG_INFO, "replay", "%s: %zu records, %llu steps; groom %s, backend %s", a->d.replay, a->replay.n,
             (unsigned long long)a->replay.end_step, s->groom, s->backend == SIM_BACKEND_CPU ? "cpu" : "vulkan");
    return CORE_OK;
}

/* Starts the --record file with the initial state the world was set up with. */
static core_status open_record(app *a, core_err *err)
{
    app_rec_start s = { .strands = a->d.strands, .verts = a->d.verts, .seed = a->d.seed, .backend = a->w.backend,
                        .threads = a->d.threads, .params = a->w.params };
    snprintf(s.groom, sizeof s.groom, "%s", a->d.groom);
    snprintf(s.collider, sizeof s.collider, "%s", a->d.collider ? a->d.collider : "");
    core_status st = app_record_open(&a->rec, a->d.record, &s, &a->parser, a->d.record_digests, err);
    if (st == CORE_OK) a->w.rec = &a->rec;
    return st;
}

static core_status setup(app *a, core_err *err)
{
    core_status st = app_parser_init(&a->parser, err);
    if (st != CORE_OK) return st;
    app_stats_board_init(&a->board);
    if ((st = app_mailbox_init(&a->mb, err)) != CORE_OK) return st;
    app_assets_list(&a->assets, a->d.assets_dir, &a->parser);
    if (a->d.replay && (st = open_replay(a, err)) != CORE_OK) return st;
    if ((st = setup_world(a, a->parser.params, a->parser.nparams, err)) != CORE_OK) return st;
    if (a->d.record && (st = open_record(a, err)) != CORE_OK) return st;
    a->gate = (app_gate){ &a->parser, &a->mb, &a->out, &a->board, &a->grooms_pending, &a->w.done, a->d.token, a->d.room, { 0 }, a->w.rec, NULL };
    if (!a->d.no_net) {
        net_desc nd = {
            .listen = a->d.listen, .port = a->d.port, .web_dir = a->d.web_dir, .subprotocol = PROTO_SUBPROTOCOL,
            .max_message = PROTO_MAX_MESSAGE, .sndbuf = a->d.client_buffer, .max_clients = a->d.max_clients,
            .allow_origins = a->d.allow_origins, .tls_cert = a->d.tls_cert, .tls_key = a->d.tls_key,
            .page_prefix = PROTO_ROOM_PREFIX, .ping_s = a->d.ping_interval, .hangup_s = a->d.ping_timeout, .blobs = { APP_MESH_PATH, APP_GROOM_PATH, APP_HAIRMESH_PATH },
            .cb = { &a->gate, app_on_open, app_on_text, app_on_close, app_metrics },
        };
        if ((st = net_create(&a->net, &nd, err)) != CORE_OK) return st;
    }
    a->out.net = a->net;
    app_streams_init(&a->w.streams, a->net, a->d.rate, a->d.max_error, (uint32_t)a->d.keyframe_interval,
                     a->w.groom.g.nstrands, a->w.groom.g.nverts);
    if (a->d.nats && a->net) {
        app_nats_desc bd = { .url = a->d.nats, .creds = a->d.nats_creds, .room = a->d.room, .gate = a->gate };
        if ((st = app_nats_open(&a->bus, &bd, err)) != CORE_OK) return st;
        a->out.bus = &a->bus;
        a->w.streams.bus = &a->bus;
        a->gate.bus = &a->bus;
    }
    const core_hairmesh *hm = a->w.groom.g.hairmesh;
    app_streams_set_hairmesh(&a->w.streams, hm ? hm->ncols : 0, hm ? hm->nlayers : 0);
    app_groom_publish(&a->out, a->d.room, &a->w.groom);
    return CORE_OK;
}

static void teardown(app *a)
{
    net_destroy(a->net);
    a->net = NULL;
    app_world *w = &a->w;
    app_streams_free(&w->streams);
    sim_destroy(&w->sim);
    app_groom_free(&w->groom);
    free(w->xyz);
    free(w->mesh_xyz);
    app_clients_free(&w->clients);
    app_assets_free(&a->assets);
    app_gate_free(&a->gate);
    app_mailbox_free(&a->mb);
    app_stats_board_free(&a->board);
    app_replay_free(&a->replay);
}

/* Waits for SIGINT/SIGTERM (blocked, taken with sigtimedwait) or the sim thread's end. */
static void wait_for_stop(app *a, const sigset_t *set)
{
    const struct timespec tick = { 0, 50 * 1000 * 1000 };
    while (!atomic_load(&a->w.done))
        if (app_process_stop_signal(set, tick, "app")) return;
}

core_status app_run(const app_desc *desc, core_err *err)
{
    if (desc->relay) return app_relay_run(desc, err);
    sigset_t set, old;
    app_process_block_signals(&set, &old);

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
        /* the token itself is never printed or logged: the user has it in the file */
        printf("strandcastd: open %s://%s%s%s:%d/%s  (WebSocket subprotocol %s%s)\n", a->d.tls_cert ? "https" : "http",
               v6 ? "[" : "", any ? "127.0.0.1" : host, v6 ? "]" : "", net_port(a->net),
               a->d.token ? "#token=TOKEN" : "", PROTO_SUBPROTOCOL, any ? "; listening on every interface" : "");
        if (a->d.token)
            printf("strandcastd: TOKEN is the first line of the --token-file; without it a page is read-only\n");
        fflush(stdout);
        if (pthread_create(&net_thread, NULL, app_process_net_main, a->net) != 0) st = core_fail(err, CORE_EBACKEND, "cannot start the net thread");
        else net_started = true;
    }
    if (st == CORE_OK) {
        if (pthread_create(&sim_thread, NULL, app_sim_main, &a->w) != 0) st = core_fail(err, CORE_EBACKEND, "cannot start the sim thread");
        else sim_started = true;
    }
    if (st == CORE_OK) wait_for_stop(a, &set);
    atomic_store(&a->w.quit, true);
    if (sim_started) {
        app_mailbox_wake(&a->mb);
        pthread_join(sim_thread, NULL);
        if (a->w.fatal != CORE_OK) st = core_fail(err, a->w.fatal, "simulation stopped: %s", a->w.fatal_err.msg);
    }
    app_loader_join(&a->w.loader); /* a groom load still running (the sim thread has stopped) */
    app_record_close(&a->rec, a->w.step_no);
    if (net_started) {
        net_stop(a->net);
        pthread_join(net_thread, NULL);
    }
    app_nats_close(&a->bus); /* its delivery thread posts to the mailbox and net: before teardown */
    if (st == CORE_OK) {
        sim_stats ss;
        sim_get_stats(&a->w.sim, &ss);
        core_log(CORE_LOG_INFO, "app", "stopped after %llu steps (%.2f s simulated)", (unsigned long long)ss.steps, ss.sim_time);
    }
    teardown(a);
    free(a);
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    return st;
}
