/* sim_hm: collisions of the hair mesh's outer surface vertices with the character's colliders
 * (spheres, capsules, ellipsoids) and its collision mesh's distance grid. */
#include <math.h>

#include "sim_hm_internal.h"

/* Pushes p out of one world collider (onto its surface); true when it moved. */
static bool push_collider(const sim_wcollider *w, float p[3])
{
    if (p[0] < w->lo[0] || p[0] > w->hi[0] || p[1] < w->lo[1] || p[1] > w->hi[1] || p[2] < w->lo[2] || p[2] > w->hi[2])
        return false;
    if (w->kind == CORE_COLLIDER_ELLIPSOID) {
        const float *M = w->to_unit, *N = w->from_unit;
        const float dx = p[0] - w->a.x, dy = p[1] - w->a.y, dz = p[2] - w->a.z;
        float sx = M[0] * dx + M[1] * dy + M[2] * dz, sy = M[3] * dx + M[4] * dy + M[5] * dz;
        float sz = M[6] * dx + M[7] * dy + M[8] * dz;
        const float sl = sqrtf(sx * sx + sy * sy + sz * sz);
        if (!(sl < 1.0f)) return false;
        if (sl < 1e-12f) sx = 0.0f, sy = 1.0f, sz = 0.0f;
        else sx /= sl, sy /= sl, sz /= sl;
        p[0] = w->a.x + N[0] * sx + N[1] * sy + N[2] * sz;
        p[1] = w->a.y + N[3] * sx + N[4] * sy + N[5] * sz;
        p[2] = w->a.z + N[6] * sx + N[7] * sy + N[8] * sz;
        return true;
    }
    float t = ((p[0] - w->a.x) * w->axis[0] + (p[1] - w->a.y) * w->axis[1] + (p[2] - w->a.z) * w->axis[2]) * w->inv_axis2;
    t = t < 0.0f ? 0.0f : t > 1.0f ? 1.0f : t;
    const float cx = w->a.x + w->axis[0] * t, cy = w->a.y + w->axis[1] * t, cz = w->a.z + w->axis[2] * t;
    const float dx = p[0] - cx, dy = p[1] - cy, dz = p[2] - cz;
    const float dl = sqrtf(dx * dx + dy * dy + dz * dz);
    if (!(dl < w->radius)) return false;
    if (dl < 1e-12f) {
        p[0] = cx, p[1] = cy + w->radius, p[2] = cz;
        return true;
    }
    const float k = w->radius / dl;
    p[0] = cx + dx * k, p[1] = cy + dy * k, p[2] = cz + dz * k;
    return true;
}

/* Pushes p out of the distance grid's surface to SIM_SDF_SKIN along the gradient (only inside
 * the grid's box, which is all the grid describes); true when it moved. */
static bool push_sdf(const core_sdf *sdf, const sim_wsdf *w, float p[3])
{
    if (p[0] < w->lo[0] || p[0] > w->hi[0] || p[1] < w->lo[1] || p[1] > w->hi[1] || p[2] < w->lo[2] || p[2] > w->hi[2])
        return false;
    const float *M = w->to_head, *N = w->from_head;
    const float dx = p[0] - w->pos[0], dy = p[1] - w->pos[1], dz = p[2] - w->pos[2];
    const core_vec3 q = core_v3(M[0] * dx + M[1] * dy + M[2] * dz, M[3] * dx + M[4] * dy + M[5] * dz,
                                M[6] * dx + M[7] * dy + M[8] * dz);
    const float hx = sdf->origin.x + (float)(sdf->dims[0] - 1) * sdf->cell;
    const float hy = sdf->origin.y + (float)(sdf->dims[1] - 1) * sdf->cell;
    const float hz = sdf->origin.z + (float)(sdf->dims[2] - 1) * sdf->cell;
    if (!(q.x >= sdf->origin.x && q.x <= hx && q.y >= sdf->origin.y && q.y <= hy && q.z >= sdf->origin.z && q.z <= hz))
        return false;
    core_vec3 g;
    const float d = core_sdf_sample(sdf, q, &g);
    const float push = (float)SIM_SDF_SKIN - d, gl = core_v3_len(g);
    if (!(push > 0.0f && gl > 1e-12f)) return false;
    const float k = push / gl;
    p[0] += (N[0] * g.x + N[1] * g.y + N[2] * g.z) * k;
    p[1] += (N[3] * g.x + N[4] * g.y + N[5] * g.z) * k;
    p[2] += (N[6] * g.x + N[7] * g.y + N[8] * g.z) * k;
    return true;
}

uint32_t sim_hm_collide(sim_hm *h, const sim_step_desc *d, int k)
{
    uint32_t moved = 0;
    for (uint32_t i = 0; i < h->n; i++) {
        if (!h->surface[i] || h->fixed[i]) continue; /* roots, contacts held or pushed already */
        float *p = h->x + 3 * (size_t)i;
        const float before[3] = { p[0], p[1], p[2] };
        bool hit = false;
        for (int round = 0; round < 2; round++) {
            for (uint32_t c = 0; c < d->ncolliders; c++) hit |= push_collider(&d->col[k][c], p);
            if (d->sdf) hit |= push_sdf(d->sdf, &d->wsdf[k], p);
        }
        if (!hit) continue;
        float *u = h->push + 3 * (size_t)i;
        u[0] += p[0] - before[0], u[1] += p[1] - before[1], u[2] += p[2] - before[2];
        h->fixed[i] = 2;
        moved++;
    }
    return moved;
}
