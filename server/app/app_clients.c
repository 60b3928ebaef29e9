/* app: the sim thread's list of connected clients. */
#include <stdlib.h>
#include <string.h>

#include "app_clients.h"

app_client *app_clients_add(app_clients *cs, uint32_t id)
{
    if (cs->n == cs->cap) {
        size_t cap = cs->cap ? 2 * cs->cap : 16;
        app_client *v = realloc(cs->v, cap * sizeof *v);
        if (!v) return NULL;
        cs->v = v;
        cs->cap = cap;
    }
    app_client *c = &cs->v[cs->n++];
    memset(c, 0, sizeof *c);
    c->id = id;
    c->stream = -1;
    return c;
}

app_client *app_clients_find(app_clients *cs, uint32_t id)
{
    for (size_t i = 0; i < cs->n; i++)
        if (cs->v[i].id == id) return &cs->v[i];
    return NULL;
}

void app_clients_remove(app_clients *cs, uint32_t id)
{
    app_client *c = app_clients_find(cs, id);
    if (c) *c = cs->v[--cs->n];
}

void app_clients_free(app_clients *cs)
{
    free(cs->v);
    memset(cs, 0, sizeof *cs);
}
