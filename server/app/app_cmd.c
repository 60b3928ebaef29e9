/* app: carries out client commands on the sim thread (at a step boundary) and replies. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app_cmd.h"
#include "app_play.h"

void app_cmd_tell_failure(app_world *w, int stream, uint32_t client)
{
    proto_error e;
    if (!app_stream_failure(&w->streams, stream, &e)) return;
    for (size_t k = 0; k < w->clients.n; k++) {
        const app_client *c = &w->clients.v[k];
        if (c->stream == stream && (client == NET_ALL || c->id == client))
            app_send(w->out, c->id, proto_build_error(NULL, &e), 0);
    }
}

/* The step a change made now first shows in: the next one the simulation takes. */
static int64_t next_step(const app_world *w)
{
    return (int64_t)app_world_snapshot(w).sim_step + 1;
}

static void broadcast_state(app_world *w)
{
    proto_state s = app_world_state(w);
    app_send(w->out, NET_ALL, proto_build_state(NULL, &s), APP_ANNOUNCE_STATE);
}

static proto_stream stream_info(const app_world *w, const app_client *c)
{
    uint32_t k = c->stream >= 0 ? w->streams.s[c->stream].decimation : app_stream_decimation(w->d->rate, c->max_rate);
    if (c->source == PROTO_SOURCE_HAIRMESH)
        return (proto_stream){ "hairmesh", 1, w->streams.ncols, c->max_error, c->max_rate, w->d->rate, w->d->rate / k,
                               w->d->keyframe_interval };
    proto_stream s = { "strand", c->stride, app_stream_strands(w->groom.g.nstrands, c->stride), c->max_error, c->max_rate,
                       w->d->rate, w->d->rate / k, w->d->keyframe_interval };
    return s;
}

/* The rate cap net applies to the client's frames: its max_rate where its stream is faster (a
 * fallback stream, or one that could not be thinned to it), else none: a stream already at the
 * client's rate is not thinned again, which would drop frames that arrive unevenly (through an
 * edge relay). */
static double delivery_cap(const app_world *w, const app_client *c)
{
    proto_stream s = stream_info(w, c);
    return c->max_rate > 0 && s.frame_rate > c->max_rate * (1 + 1e-9) ? c->max_rate : 0;
}

static void client_open(app_world *w, uint32_t id)
{
    app_client *c = app_clients_add(&w->clients, id);
    if (!c) return;
    c->stride = 1;
    c->max_error = w->d->max_error;
    c->stream = app_stream_acquire(&w->streams, PROTO_SOURCE_STRANDS, c->stride, c->max_error, c->max_rate);
    const app_assets *as = w->assets;
    proto_hello h = {
        .server = "strandcastd", .version = STRANDCAST_VERSION, .client = id, .groom = &w->groom.json,
        .head = app_anim_pose(&w->anim), .params = w->ptable, .nparams = w->nparams,
        .values = &w->params, .presets = app_preset_names, .npresets = APP_PRESET_COUNT,
        .animation = { app_preset_names[w->anim.preset], w->anim.speed }, .styles = w->styles, .nstyles = APP_NSTYLES,
        .files = (const char *const *)as->files, .nfiles = as->nfiles,
        .meshes = (const char *const *)as->meshes, .nmeshes = as->nmeshes, .stream = stream_info(w, c),
        .state = app_world_state(w), .token_required = w->d->token != NULL, .room = w->d->room,
    };
    char *hello = proto_build_hello(&h);
    if (!hello) {
        core_log(CORE_LOG_ERROR, "app", "client %u: out of memory building the hello", id);
        return;
    }
    uint32_t stream = c->stream >= 0 ? (uint32_t)c->stream : NET_MAX_STREAMS;
    app_out_start(w->out, id, hello, stream, delivery_cap(w, c));
    proto_free(hello);
    app_cmd_tell_failure(w, c->stream, id);
    w->dirty = w->dirty || w->paused; /* a paused server still shows the newcomer a frame */
}

static void client_close(app_world *w, uint32_t id)
{
    app_client *c = app_clients_find(&w->clients, id);
    if (!c) return;
    app_stream_release(&w->streams, c->stream);
    app_clients_remove(&w->clients, id);
}

static void set_params(app_world *w, uint32_t client, const proto_msg *m)
{
    sim_params p = w->params;
    bool changed[PROTO_MAX_PARAMS] = { false };
    for (uint32_t i = 0; i < m->u.set_params.count; i++) {
        const proto_param_value *v = &m->u.set_params.v[i];
        const core_param_info *t = &w->ptable[v->index];
        char *field = (char *)&p + t->offset;
        switch (t->type) {
        case CORE_PARAM_FLOAT: *(float *)field = (float)v->value; break;
        case CORE_PARAM_INT:
        case CORE_PARAM_ENUM: *(int32_t *)field = (int32_t)v->value; break;
        case CORE_PARAM_BOOL: *(bool *)field = v->value != 0.0; break;
        }
        changed[v->index] = true;
    }
    core_err err;
    if (p.solver != w->params.solver &&
        app_budget_check(app_budget_rate(&w->budget, p.solver), w->d->min_step_rate, p.solver, w->groom.g.nstrands,
                         w->groom.g.nverts, &err) != CORE_OK) {
        app_reply_fail(w->out, client, &m->id, PROTO_ERR_TOO_LARGE, "values.solver", err.msg);
        return;
    }
    /* a new solver takes the hair over where it is (sim_change) */
    if (sim_change(&w->sim, &w->groom.g, &p, &err) != CORE_OK) {
        app_reply_fail(w->out, client, &m->id, PROTO_ERR_OUT_OF_RANGE, "values", err.msg);
        return;
    }
    w->params = p;
    app_play_record(w, m);
    app_reply_ok(w->out, client, m, next_step(w));
    app_send(w->out, NET_ALL, proto_build_params(NULL, w->ptable, w->nparams, &w->params, changed, client),
             APP_ANNOUNCE_PARAMS);
    app_cmd_hairmesh_fallback(w); /* a solver without a hair mesh: its subscribers back to strands */
}

static void motion(app_world *w, uint32_t client, const proto_msg *m)
{
    app_client *c = app_clients_find(&w->clients, client);
    if (c && m->u.motion.has_t) {
        if (c->has_t && m->u.motion.t < c->last_t) { /* stale: a newer pose was applied */
            if (m->id.kind == PROTO_ID_NONE) return;
            proto_error e;
            proto_fail(&e, PROTO_ERR_BAD_STATE, "t", "stale motion: t %.17g is older than the last applied t %.17g",
                       m->u.motion.t, c->last_t);
            app_reply_error(w->out, client, &m->id, &e);
            return;
        }
        c->has_t = true;
        c->last_t = m->u.motion.t;
    }
    core_xform base = { m->u.motion.position, m->u.motion.orientation };
    bool stopped = app_anim_motion(&w->anim, base);
    app_play_record(w, m);
    if (m->id.kind != PROTO_ID_NONE) app_reply_ok(w->out, client, m, next_step(w));
    else app_count_accepted(w->out);
    if (stopped) broadcast_state(w);
}

/* True when the active solver simulates the groom's hair mesh (hair mesh streams can be fed). */
static bool has_hairmesh(const app_world *w)
{
    return w->groom.g.hairmesh && w->streams.ncols && w->sim.vt && w->sim.vt->read_hairmesh;
}

/* Moves client c to the strand stream of its settings and tells it with an unsolicited
 * subscribed (its hair mesh went away). Keeps it where it is when no stream slot is left. */
static void fall_back(app_world *w, app_client *c)
{
    int stream = app_stream_acquire(&w->streams, PROTO_SOURCE_STRANDS, c->stride, c->max_error, c->max_rate);
    if (stream < 0) {
        core_log(CORE_LOG_WARN, "app", "client %u: no stream slot to move it from the hair mesh to strands", c->id);
        return;
    }
    app_stream_release(&w->streams, c->stream);
    c->stream = stream;
    c->source = PROTO_SOURCE_STRANDS;
    app_out_subscribe(w->out, c->id, (uint32_t)stream, delivery_cap(w, c));
    proto_stream s = stream_info(w, c);
    app_send(w->out, c->id, proto_build_subscribed(&(proto_id){ .kind = PROTO_ID_NONE }, &s), 0);
    w->dirty = true;
}

void app_cmd_hairmesh_fallback(app_world *w)
{
    if (has_hairmesh(w)) return;
    for (size_t i = 0; i < w->clients.n; i++)
        if (w->clients.v[i].source == PROTO_SOURCE_HAIRMESH) fall_back(w, &w->clients.v[i]);
}

static void subscribe(app_world *w, uint32_t client, const proto_msg *m)
{
    app_client *c = app_clients_find(&w->clients, client);
    if (!c) return;
    int32_t stride = m->u.subscribe.has_stride ? m->u.subscribe.stride : c->stride;
    double max_error = m->u.subscribe.has_max_error ? m->u.subscribe.max_error : c->max_error;
    double max_rate = m->u.subscribe.has_max_rate ? m->u.subscribe.max_rate : c->max_rate;
    proto_source source = m->u.subscribe.has_source ? m->u.subscribe.source : c->source;
    if (source == PROTO_SOURCE_HAIRMESH && !has_hairmesh(w)) {
        char why[160];
        if (w->groom.g.hairmesh)
            snprintf(why, sizeof why, "source hairmesh needs the hairmesh solver: the %s solver simulates strands",
                     w->sim.vt ? w->sim.vt->name : "current");
        else
            snprintf(why, sizeof why, "source hairmesh needs a groom traced through a hair mesh (groom.hairmesh is null)");
        app_reply_fail(w->out, client, &m->id, PROTO_ERR_BAD_STATE, "source", why);
        return;
    }
    int stream = app_stream_acquire(&w->streams, source, stride, max_error, max_rate);
    if (stream < 0) {
        app_reply_fail(w->out, client, &m->id, PROTO_ERR_BUSY, "",
                       "every stream slot is taken by other stride/max_error/rate settings; pick settings another client uses");
        return;
    }
    if (!w->streams.s[stream].ready) {
        app_stream_release(&w->streams, stream);
        app_reply_fail(w->out, client, &m->id, PROTO_ERR_FAILED, "", "the stream's encoder could not be set up (see the server log)");
        return;
    }
    app_stream_release(&w->streams, c->stream);
    c->stream = stream;
    c->source = source;
    c->stride = stride;
    c->max_error = max_error;
    c->max_rate = max_rate;
    app_out_subscribe(w->out, client, (uint32_t)stream, delivery_cap(w, c));
    w->dirty = w->dirty || w->paused;
    app_count_accepted(w->out);
    proto_stream s = stream_info(w, c);
    app_send(w->out, client, proto_build_subscribed(&m->id, &s), 0);
    app_cmd_tell_failure(w, stream, client); /* joined a stream whose frames are not being sent */
}

static void handle_msg(app_world *w, uint32_t client, const proto_msg *m)
{
    if (app_play_refuse(w, client, m)) return;
    switch (m->type) {
    case PROTO_GET_PARAMS:
        app_count_accepted(w->out);
        app_send(w->out, client, proto_build_params(&m->id, w->ptable, w->nparams, &w->params, NULL, -1), 0);
        return;
    case PROTO_SET_PARAMS: set_params(w, client, m); return;
    case PROTO_MOTION: motion(w, client, m); return;
    case PROTO_ANIMATE:
        app_anim_start(&w->anim, (app_preset)m->u.animate.preset, m->u.animate.speed);
        break;
    case PROTO_RESET:
        app_world_reset(w);
        app_streams_force_keys(&w->streams);
        w->dirty = true;
        break;
    case PROTO_PAUSE:
        w->paused = true;
        w->step_budget = 0;
        break;
    case PROTO_RESUME:
        w->paused = false;
        w->step_budget = 0;
        break;
    case PROTO_STEP: {
        if (!w->paused) {
            app_reply_fail(w->out, client, &m->id, PROTO_ERR_BAD_STATE, "", "step works while paused; send pause first");
            return;
        }
        const int64_t first = next_step(w) + w->step_budget; /* after the steps still owed */
        w->step_budget += m->u.step.count;
        app_play_record(w, m);
        if (w->step_budget > PROTO_MAX_STEP) w->step_budget = PROTO_MAX_STEP;
        app_reply_ok(w->out, client, m, first);
        return; /* the state follows when the steps are done */
    }
    case PROTO_SET_GROOM: app_cmd_set_groom(w, client, m); return; /* it drops grooms_pending */
    case PROTO_AUTH: return; /* answered on the net thread (app_net.c), never queued */
    case PROTO_SUBSCRIBE: subscribe(w, client, m); return;
    case PROTO_KEYFRAME: {
        app_client *c = app_clients_find(&w->clients, client);
        if (c) app_stream_force_key(&w->streams, c->stream);
        w->dirty = w->dirty || w->paused;
        app_reply_ok(w->out, client, m, -1);
        return;
    }
    }
    /* reset: the rest pose at step 0 (published at once); pause: no step after the current one */
    int64_t shows = m->type == PROTO_RESET ? 0 : m->type == PROTO_PAUSE ? next_step(w) - 1 : next_step(w);
    app_play_record(w, m); /* animate, reset, pause, resume */
    app_reply_ok(w->out, client, m, shows);
    broadcast_state(w);
}

void app_cmd_handle(app_world *w, app_cmd *c)
{
    switch (c->kind) {
    case APP_CMD_OPEN: client_open(w, c->client); break;
    case APP_CMD_CLOSE: client_close(w, c->client); break;
    case APP_CMD_MSG: handle_msg(w, c->client, &c->msg); break;
    }
}
