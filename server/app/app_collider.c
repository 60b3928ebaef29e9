/* app: a groom's collision mesh (its SDF over groom_collider_region, the binary for clients), and
 * handing the groom's binaries to net. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app_groom.h"
#include "app_nats.h"
#include "app_outbox.h"
#include "groom/groom.h"

/* Drops g's mesh, grid and binary. */
static void clear(app_groom *g)
{
    if (g->g.mesh) core_mesh_free(g->g.mesh);
    if (g->g.sdf) core_sdf_free(g->g.sdf);
    free(g->g.mesh);
    free(g->g.sdf);
    g->g.mesh = NULL;
    g->g.sdf = NULL;
    net_buf_unref(g->mesh_bin);
    g->mesh_bin = NULL;
    g->collider[0] = '\0';
    g->mesh_etag[0] = '\0';
    g->sdf_ms = 0.0;
}

static core_status attach(app_groom *g, core_mesh *mesh, const char *label, core_err *err)
{
    g->g.mesh = malloc(sizeof *g->g.mesh);
    if (!g->g.mesh) {
        core_mesh_free(mesh);
        return core_fail(err, CORE_ENOMEM, "out of memory for the collision mesh");
    }
    *g->g.mesh = *mesh;
    memset(mesh, 0, sizeof *mesh);
    snprintf(g->collider, sizeof g->collider, "%s", label);
    core_vec3 lo, hi;
    if (groom_collider_region(&g->g, g->g.mesh, &lo, &hi)) {
        g->g.sdf = calloc(1, sizeof *g->g.sdf);
        if (!g->g.sdf) return core_fail(err, CORE_ENOMEM, "out of memory for the collision grid");
        groom_sdf_desc sd = { .cell = GROOM_SDF_DEFAULT_CELL, .lo = lo, .hi = hi, .max_cells = GROOM_COLLIDER_MAX_CELLS };
        unsigned long long t0 = core_now_ns();
        core_status st = groom_sdf_build(g->g.mesh, &sd, g->g.sdf, err);
        g->sdf_ms = (double)(core_now_ns() - t0) / 1e6;
        if (st != CORE_OK) return st;
    } else {
        core_log(CORE_LOG_INFO, "app", "collider %s: out of the hair's reach, no distance grid", label);
    }
    size_t n = proto_mesh_bin_size(g->g.mesh);
    g->mesh_bin = net_buf_new(n);
    if (!g->mesh_bin) return core_fail(err, CORE_ENOMEM, "out of memory for the collision mesh binary");
    proto_mesh_bin_write(g->g.mesh, net_buf_data(g->mesh_bin));
    proto_bin_etag(net_buf_data(g->mesh_bin), n, g->mesh_etag);
    return CORE_OK;
}

core_status app_groom_set_collider(app_groom *g, core_mesh *mesh, const char *label, core_err *err)
{
    clear(g);
    core_status st = mesh ? attach(g, mesh, label, err) : CORE_OK;
    if (st != CORE_OK) {
        clear(g);
        app_groom_render(g, NULL);
        return st;
    }
    return app_groom_render(g, err);
}

/* Hands one binary (new references) to net at path and at the room's page path, and to the
 * NATS bridge. */
static void publish(app_outbox *o, const char *room, const char *path, net_buf *b, const char *etag)
{
    char rpath[NET_MAX_BLOB_PATH];
    snprintf(rpath, sizeof rpath, PROTO_ROOM_PREFIX "%s%s", room, path);
    const char *paths[] = { path, rpath };
    for (int i = 0; i < 2 && o->net; i++) {
        if (b) net_buf_ref(b);
        if (net_set_blob(o->net, paths[i], b, etag) != CORE_OK)
            core_log(CORE_LOG_ERROR, "app", "%s could not be handed to net", paths[i]);
    }
    if (o->bus) app_nats_blob(o->bus, path, b, etag);
}

void app_groom_publish(app_outbox *out, const char *room, const app_groom *g)
{
    publish(out, room, APP_GROOM_PATH, g->groom_bin, g->groom_etag);
    publish(out, room, APP_HAIRMESH_PATH, g->hairmesh_bin, g->hairmesh_etag);
    publish(out, room, APP_MESH_PATH, g->mesh_bin, g->mesh_etag);
}
