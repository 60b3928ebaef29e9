/* app: a groom's collision mesh: loading, the region its SDF covers, the SDF, the binary for clients. */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app_internal.h"
#include "groom/groom.h"

bool app_collider_region(const core_groom *g, const core_mesh *m, core_vec3 *lo, core_vec3 *hi)
{
    float rlo[3] = { FLT_MAX, FLT_MAX, FLT_MAX }, rhi[3] = { -FLT_MAX, -FLT_MAX, -FLT_MAX };
    double longest = 0.0;
    bool any = false;
    for (size_t s = 0; s < g->nstrands; s++) {
        const float *p = g->pos + 3 * s * g->nverts;
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) continue;
        any = true;
        for (int k = 0; k < 3; k++) {
            rlo[k] = fminf(rlo[k], p[k]);
            rhi[k] = fmaxf(rhi[k], p[k]);
        }
        double len = 0.0;
        for (size_t v = 1; v < g->nverts; v++) {
            const float *a = p + 3 * (v - 1), *b = p + 3 * v;
            double d = sqrt((double)(b[0] - a[0]) * (b[0] - a[0]) + (double)(b[1] - a[1]) * (b[1] - a[1]) +
                            (double)(b[2] - a[2]) * (b[2] - a[2]));
            if (isfinite(d)) len += d;
        }
        if (len > longest) longest = len;
    }
    if (!any || !m->nverts) return false;
    float mlo[3] = { FLT_MAX, FLT_MAX, FLT_MAX }, mhi[3] = { -FLT_MAX, -FLT_MAX, -FLT_MAX };
    for (size_t i = 0; i < m->nverts; i++)
        for (int k = 0; k < 3; k++) {
            mlo[k] = fminf(mlo[k], m->pos[3 * i + k]);
            mhi[k] = fmaxf(mhi[k], m->pos[3 * i + k]);
        }
    float reach = (float)longest + APP_COLLIDER_REACH_PAD, out_lo[3], out_hi[3];
    for (int k = 0; k < 3; k++) {
        out_lo[k] = fmaxf(rlo[k] - reach, mlo[k] - APP_COLLIDER_MESH_PAD);
        out_hi[k] = fminf(rhi[k] + reach, mhi[k] + APP_COLLIDER_MESH_PAD);
        if (!(out_lo[k] < out_hi[k])) return false;
    }
    *lo = core_v3(out_lo[0], out_lo[1], out_lo[2]);
    *hi = core_v3(out_hi[0], out_hi[1], out_hi[2]);
    return true;
}

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
    if (app_collider_region(&g->g, g->g.mesh, &lo, &hi)) {
        g->g.sdf = calloc(1, sizeof *g->g.sdf);
        if (!g->g.sdf) return core_fail(err, CORE_ENOMEM, "out of memory for the collision grid");
        groom_sdf_desc sd = { .cell = GROOM_SDF_DEFAULT_CELL, .lo = lo, .hi = hi, .max_cells = APP_COLLIDER_MAX_CELLS };
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
    proto_mesh_bin_etag(net_buf_data(g->mesh_bin), n, g->mesh_etag);
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

void app_publish_mesh(app *a)
{
    if (!a->net) return;
    net_buf *b = a->groom.mesh_bin;
    if (b) net_buf_ref(b);
    if (net_set_blob(a->net, APP_MESH_PATH, b, a->groom.mesh_etag) != CORE_OK)
        core_log(CORE_LOG_ERROR, "app", "the collision mesh could not be handed to net");
}
