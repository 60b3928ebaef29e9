/* app: the net thread's per-client entries (access, token bucket) in an open-addressed table
 * (linear probing, backward-shift deletion). */
#include <stdlib.h>
#include <string.h>

#include "app_peers.h"

static size_t home(const app_peers *r, uint32_t client) { return (size_t)(client * 2654435761u) & (r->cap - 1); }

/* The slot of client, or of the empty slot where it would go. cap > 0. */
static size_t find(const app_peers *r, uint32_t client)
{
    size_t i = home(r, client);
    while (r->v[i].client && r->v[i].client != client) i = (i + 1) & (r->cap - 1);
    return i;
}

static core_status grow(app_peers *r)
{
    size_t cap = r->cap ? 2 * r->cap : 64;
    app_peer *v = calloc(cap, sizeof *v);
    if (!v) return CORE_ENOMEM;
    app_peers old = *r;
    r->v = v;
    r->cap = cap;
    for (size_t i = 0; i < old.cap; i++)
        if (old.v[i].client) r->v[find(r, old.v[i].client)] = old.v[i];
    free(old.v);
    return CORE_OK;
}

core_status app_peers_open(app_peers *r, uint32_t client, bool writer, unsigned long long now_ns)
{
    if (2 * (r->n + 1) > r->cap && grow(r) != CORE_OK) return CORE_ENOMEM;
    size_t i = find(r, client);
    if (!r->v[i].client) r->n++;
    r->v[i] = (app_peer){ client, writer, APP_RATE_BURST, now_ns };
    return CORE_OK;
}

void app_peers_close(app_peers *r, uint32_t client)
{
    if (!r->cap) return;
    size_t i = find(r, client);
    if (!r->v[i].client) return;
    r->v[i].client = 0;
    r->n--;
    /* backward shift: pull later entries of the run into the hole when their home allows it */
    for (size_t j = (i + 1) & (r->cap - 1); r->v[j].client; j = (j + 1) & (r->cap - 1)) {
        size_t h = home(r, r->v[j].client);
        bool movable = i <= j ? (h <= i || h > j) : (h <= i && h > j);
        if (movable) {
            r->v[i] = r->v[j];
            r->v[j].client = 0;
            i = j;
        }
    }
}

app_peer *app_peers_find(app_peers *r, uint32_t client)
{
    if (!r->cap) return NULL;
    app_peer *p = &r->v[find(r, client)];
    return p->client ? p : NULL;
}

bool app_peers_take(app_peers *r, uint32_t client, unsigned long long now_ns)
{
    if (!r->cap) return true;
    app_peer *s = &r->v[find(r, client)];
    if (!s->client) return true;
    double refill = (double)(now_ns - s->t_ns) * 1e-9 * APP_RATE_PER_S;
    s->tokens = s->tokens + refill < APP_RATE_BURST ? s->tokens + refill : APP_RATE_BURST;
    s->t_ns = now_ns;
    if (s->tokens < 1.0) return false;
    s->tokens -= 1.0;
    return true;
}

void app_peers_free(app_peers *r)
{
    free(r->v);
    memset(r, 0, sizeof *r);
}

char *app_peers_limited(const proto_parser *p, const char *text, size_t len)
{
    proto_msg m;
    proto_error e;
    proto_parse(p, text, len, &m, &e); /* only for the id */
    proto_fail(&e, PROTO_ERR_RATE_LIMITED, "",
               "over the budget of %.0f control messages a second (%.0f at once); this one was not carried out",
               APP_RATE_PER_S, APP_RATE_BURST);
    return proto_build_error(&m.id, &e);
}
