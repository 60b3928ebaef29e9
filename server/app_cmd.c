/* app: carries out client commands on the sim thread (at a step boundary) and replies. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app_internal.h"

static app_client *find_client(app *a, uint32_t id)
{
    for (size_t i = 0; i < a->nclients; i++)
        if (a->clients[i].id == id) return &a->clients[i];
    return NULL;
}

void app_reply_fail(app *a, uint32_t client, const proto_id *id, proto_code code, const char *field, const char *msg)
{
    proto_error e;
    proto_fail(&e, code, field, "%s", msg);
    app_reply_error(a, client, id, &e);
}

void app_reply_ok(app *a, uint32_t client, const proto_msg *m)
{
    atomic_fetch_add(&a->accepted, 1);
    app_send(a, client, proto_build_ok(&m->id, m->type), 0);
}

static void broadcast_state(app *a)
{
    proto_state s = app_state(a);
    app_send(a, NET_ALL, proto_build_state(NULL, &s), 0);
}

static proto_stream stream_info(const app *a, const app_client *c)
{
    uint32_t k = c->tier >= 0 ? a->tiers[c->tier].decimation : app_stream_decimation(a->d.rate, c->max_rate);
    proto_stream s = { "strand", c->stride, app_tier_strands(a, c->stride), c->max_error, c->max_rate,
                       a->d.rate, a->d.rate / k, a->d.keyframe_interval };
    return s;
}

static void client_open(app *a, uint32_t id)
{
    if (a->nclients == a->cap_clients) {
        size_t cap = a->cap_clients ? 2 * a->cap_clients : 16;
        app_client *c = realloc(a->clients, cap * sizeof *c);
        if (!c) return;
        a->clients = c;
        a->cap_clients = cap;
    }
    app_client *c = &a->clients[a->nclients++];
    memset(c, 0, sizeof *c);
    c->id = id;
    c->stride = 1;
    c->max_error = a->d.max_error;
    c->tier = app_tier_acquire(a, c->stride, c->max_error, c->max_rate);
    const char *styles[3] = { a->styles[0], a->styles[1], a->styles[2] };
    proto_hello h = {
        .server = "strandcastd", .version = STRANDCAST_VERSION, .client = id, .groom = &a->groom.json,
        .head = app_anim_pose(&a->anim), .params = a->ptable, .nparams = a->nparams,
        .values = &a->params, .presets = app_preset_names, .npresets = APP_PRESET_COUNT,
        .animation = { app_preset_names[a->anim.preset], a->anim.speed }, .styles = styles, .nstyles = 3,
        .files = (const char *const *)a->files, .nfiles = a->nfiles,
        .meshes = (const char *const *)a->meshes, .nmeshes = a->nmeshes, .stream = stream_info(a, c), .state = app_state(a),
    };
    char *hello = proto_build_hello(&h);
    if (!hello) {
        core_log(CORE_LOG_ERROR, "app", "client %u: out of memory building the hello", id);
        return;
    }
    uint32_t stream = c->tier >= 0 ? (uint32_t)c->tier : NET_MAX_STREAMS;
    if (a->net) net_start_client(a->net, id, hello, strlen(hello), stream, c->max_rate);
    proto_free(hello);
    app_tier_tell_failure(a, c->tier, id);
    a->dirty = a->dirty || a->paused; /* a paused server still shows the newcomer a frame */
}

static void client_close(app *a, uint32_t id)
{
    app_client *c = find_client(a, id);
    if (!c) return;
    app_tier_release(a, c->tier);
    *c = a->clients[--a->nclients];
}

static void set_params(app *a, uint32_t client, const proto_msg *m)
{
    sim_params p = a->params;
    bool changed[PROTO_MAX_PARAMS] = { false };
    for (uint32_t i = 0; i < m->u.set_params.count; i++) {
        const proto_param_value *v = &m->u.set_params.v[i];
        const core_param_info *t = &a->ptable[v->index];
        char *field = (char *)&p + t->offset;
        switch (t->type) {
        case CORE_PARAM_FLOAT: *(float *)field = (float)v->value; break;
        case CORE_PARAM_INT: *(int32_t *)field = (int32_t)v->value; break;
        case CORE_PARAM_BOOL: *(bool *)field = v->value != 0.0; break;
        }
        changed[v->index] = true;
    }
    core_err err;
    if (sim_set_params(&a->sim, &p, &err) != CORE_OK) {
        app_reply_fail(a, client, &m->id, PROTO_ERR_OUT_OF_RANGE, "values", err.msg);
        return;
    }
    a->params = p;
    app_reply_ok(a, client, m);
    app_send(a, NET_ALL, proto_build_params(NULL, a->ptable, a->nparams, &a->params, changed, client), 0);
}

static void motion(app *a, uint32_t client, const proto_msg *m)
{
    app_client *c = find_client(a, client);
    if (c && m->u.motion.has_t) {
        if (c->has_t && m->u.motion.t < c->last_t) { /* stale: a newer pose was applied */
            if (m->id.kind == PROTO_ID_NONE) return;
            proto_error e;
            proto_fail(&e, PROTO_ERR_BAD_STATE, "t", "stale motion: t %.17g is older than the last applied t %.17g",
                       m->u.motion.t, c->last_t);
            app_reply_error(a, client, &m->id, &e);
            return;
        }
        c->has_t = true;
        c->last_t = m->u.motion.t;
    }
    core_xform base = { m->u.motion.position, m->u.motion.orientation };
    bool stopped = app_anim_motion(&a->anim, base);
    if (m->id.kind != PROTO_ID_NONE) app_reply_ok(a, client, m);
    else atomic_fetch_add(&a->accepted, 1);
    if (stopped) broadcast_state(a);
}

void app_reset_sim(app *a)
{
    sim_reset(&a->sim);
    pthread_mutex_lock(&a->stats_mu);
    a->stats.nan_resets = 0;
    pthread_mutex_unlock(&a->stats_mu);
}

static void subscribe(app *a, uint32_t client, const proto_msg *m)
{
    app_client *c = find_client(a, client);
    if (!c) return;
    int32_t stride = m->u.subscribe.has_stride ? m->u.subscribe.stride : c->stride;
    double max_error = m->u.subscribe.has_max_error ? m->u.subscribe.max_error : c->max_error;
    double max_rate = m->u.subscribe.has_max_rate ? m->u.subscribe.max_rate : c->max_rate;
    int tier = app_tier_acquire(a, stride, max_error, max_rate);
    if (tier < 0) {
        app_reply_fail(a, client, &m->id, PROTO_ERR_BUSY, "",
                   "every stream slot is taken by other stride/max_error/rate settings; pick settings another client uses");
        return;
    }
    if (!a->tiers[tier].ready) {
        app_tier_release(a, tier);
        app_reply_fail(a, client, &m->id, PROTO_ERR_FAILED, "", "the stream's encoder could not be set up (see the server log)");
        return;
    }
    app_tier_release(a, c->tier);
    c->tier = tier;
    c->stride = stride;
    c->max_error = max_error;
    c->max_rate = max_rate;
    if (a->net) net_subscribe(a->net, client, (uint32_t)tier, c->max_rate);
    a->dirty = a->dirty || a->paused;
    atomic_fetch_add(&a->accepted, 1);
    proto_stream s = stream_info(a, c);
    app_send(a, client, proto_build_subscribed(&m->id, &s), 0);
    app_tier_tell_failure(a, tier, client); /* joined a stream whose frames are not being sent */
}

static void handle_msg(app *a, uint32_t client, const proto_msg *m)
{
    switch (m->type) {
    case PROTO_GET_PARAMS:
        atomic_fetch_add(&a->accepted, 1);
        app_send(a, client, proto_build_params(&m->id, a->ptable, a->nparams, &a->params, NULL, -1), 0);
        return;
    case PROTO_SET_PARAMS: set_params(a, client, m); return;
    case PROTO_MOTION: motion(a, client, m); return;
    case PROTO_ANIMATE:
        app_anim_start(&a->anim, (app_preset)m->u.animate.preset, m->u.animate.speed);
        break;
    case PROTO_RESET:
        app_reset_sim(a);
        for (int i = 0; i < NET_MAX_STREAMS; i++) a->tiers[i].force_key = true;
        a->dirty = true;
        break;
    case PROTO_PAUSE:
        a->paused = true;
        a->step_budget = 0;
        break;
    case PROTO_RESUME:
        a->paused = false;
        a->step_budget = 0;
        break;
    case PROTO_STEP:
        if (!a->paused) {
            app_reply_fail(a, client, &m->id, PROTO_ERR_BAD_STATE, "", "step works while paused; send pause first");
            return;
        }
        a->step_budget += m->u.step.count;
        if (a->step_budget > PROTO_MAX_STEP) a->step_budget = PROTO_MAX_STEP;
        app_reply_ok(a, client, m);
        return; /* the state follows when the steps are done */
    case PROTO_SET_GROOM: app_set_groom(a, client, m); return; /* it drops grooms_pending */
    case PROTO_SUBSCRIBE: subscribe(a, client, m); return;
    case PROTO_KEYFRAME: {
        app_client *c = find_client(a, client);
        if (c && c->tier >= 0) a->tiers[c->tier].force_key = true;
        a->dirty = a->dirty || a->paused;
        app_reply_ok(a, client, m);
        return;
    }
    }
    app_reply_ok(a, client, m);
    broadcast_state(a);
}

void app_handle(app *a, app_cmd *c)
{
    switch (c->kind) {
    case APP_CMD_OPEN: client_open(a, c->client); break;
    case APP_CMD_CLOSE: client_close(a, c->client); break;
    case APP_CMD_MSG: handle_msg(a, c->client, &c->msg); break;
    }
}

proto_state app_state(const app *a)
{
    sim_stats ss;
    sim_get_stats((sim *)&a->sim, &ss);
    proto_state s = { a->paused, ss.sim_time, ss.steps, { app_preset_names[a->anim.preset], a->anim.speed } };
    return s;
}
