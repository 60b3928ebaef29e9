/* groom: fits a head sphere collider under a file groom's roots. */
#include "groom.h"
#include "groom_internal.h"

#include <math.h>

#define FIT_MARGIN 0.001f
#define FIT_MIN_AXIS_RADIUS 0.04f
#define FIT_MAX_AXIS_RADIUS 0.25f
#define FIT_MIN_RADIUS 0.005f

static core_vec3 vert(const core_groom *g, uint32_t s, uint32_t v)
{
    const float *p = g->pos + ((size_t)s * g->nverts + v) * 3;
    return core_v3(p[0], p[1], p[2]);
}

void groom_fit_colliders(core_groom *g)
{
    memset(g->colliders, 0, sizeof g->colliders);
    g->ncolliders = 0;
    if (g->nstrands == 0 || g->nverts < 2 || !g->pos) return;
    double c[3] = { 0, 0, 0 }, n[3] = { 0, 0, 0 };
    for (uint32_t s = 0; s < g->nstrands; s++) {
        core_vec3 r = vert(g, s, 0), d = core_v3_norm(core_v3_sub(vert(g, s, 1), r));
        c[0] += r.x, c[1] += r.y, c[2] += r.z;
        n[0] += d.x, n[1] += d.y, n[2] += d.z;
    }
    core_vec3 centroid = core_v3((float)(c[0] / g->nstrands), (float)(c[1] / g->nstrands), (float)(c[2] / g->nstrands));
    core_vec3 axis = core_v3((float)n[0], (float)n[1], (float)n[2]);
    axis = core_v3_len(axis) > 1e-6f * (float)g->nstrands ? core_v3_norm(axis) : core_v3(0.0f, 1.0f, 0.0f);

    float spread = 0.0f; /* largest root distance from the axis line through the centroid */
    for (uint32_t s = 0; s < g->nstrands; s++) {
        core_vec3 d = core_v3_sub(vert(g, s, 0), centroid);
        float off = core_v3_len(core_v3_sub(d, core_v3_scale(axis, core_v3_dot(d, axis))));
        if (off > spread) spread = off;
    }
    float reach = fminf(fmaxf(spread, FIT_MIN_AXIS_RADIUS), FIT_MAX_AXIS_RADIUS);
    core_vec3 centre = core_v3_sub(centroid, core_v3_scale(axis, reach));
    float rmin = INFINITY;
    for (uint32_t s = 0; s < g->nstrands; s++) rmin = fminf(rmin, core_v3_len(core_v3_sub(vert(g, s, 0), centre)));
    float radius = rmin - FIT_MARGIN;
    if (!(radius >= FIT_MIN_RADIUS) || !isfinite(radius)) return;
    core_collider *h = &g->colliders[0];
    h->kind = CORE_COLLIDER_SPHERE;
    h->a = centre;
    h->radius = radius;
    h->rot = core_q_identity();
    g->ncolliders = 1;
}
