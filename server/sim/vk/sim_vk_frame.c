/* sim_vk: the host-computed per-step parameters (substep heads, world colliders, constants). */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "sim_vk_internal.h"
#include "../sim_pbd.h"

_Static_assert(offsetof(sim_vk_frame, substeps) == 64, "frame layout must match sim_common.glsl");
_Static_assert(offsetof(sim_vk_frame, head) == 112, "frame layout must match sim_common.glsl");
_Static_assert(offsetof(sim_vk_frame, col) == 112 + 32 * SIM_MAX_SUBSTEPS, "frame layout must match sim_common.glsl");
_Static_assert(sizeof(sim_vk_gcollider) == 160, "collider layout must match sim_common.glsl");
_Static_assert(sizeof(sim_vk_gsub) == 192, "substep layout must match sim_common.glsl");
_Static_assert(offsetof(sim_vk_frame, sdf_dims) == 112 + 32 * SIM_MAX_SUBSTEPS + 160 * SIM_MAX_SUBSTEPS * SIM_MAX_COLLIDERS,
               "frame layout must match sim_common.glsl");
_Static_assert(sizeof(sim_vk_frame) % 16 == 0, "the shape weights (vec4 per level) follow the frame");
_Static_assert(sizeof(sim_shape_weights) == 4 * sizeof(float), "one vec4 of shape weights per level");

size_t sim_vk_frame_size(uint32_t nv) { return sizeof(sim_vk_frame) + (size_t)nv * sizeof(sim_shape_weights); }

static void put4(float *dst, float x, float y, float z, float w)
{
    dst[0] = x, dst[1] = y, dst[2] = z, dst[3] = w;
}

/* The shader's collider: the world collider of sim_step.c in vec4 rows. */
static void pack_collider(const sim_wcollider *w, sim_vk_gcollider *out)
{
    memset(out, 0, sizeof *out);
    put4(out->a, w->a.x, w->a.y, w->a.z, (float)w->kind);
    put4(out->b, w->b.x, w->b.y, w->b.z, w->radius);
    put4(out->lo, w->lo[0], w->lo[1], w->lo[2], 0.0f);
    put4(out->hi, w->hi[0], w->hi[1], w->hi[2], 0.0f);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) out->m[i][j] = w->to_unit[3 * i + j], out->nrm[i][j] = w->from_unit[3 * i + j];
}

void sim_vk_frame_fill(const sim_vk_frame_in *in, void *out)
{
    const sim_params *p = in->params;
    const sim_step_desc *d = in->step;
    sim_vk_frame *f = out;
    memset(f, 0, sizeof *f);
    const float h = d->sph_h;
    put4(f->accel, d->accel[0], d->accel[1], d->accel[2], d->keep);
    f->dt_k = d->h;
    f->inv_dt_k = d->inv_h;
    f->dftl = d->dftl;
    f->h = h;
    f->h2 = h * h;
    f->inv_h2 = 1.0f / f->h2;
    f->inv_h = 1.0f / h;
    f->kp = d->kp;
    f->mu_dt = d->mu_dt;
    f->inv_step_dt = 1.0f / d->dt;
    f->inv_rho0 = d->inv_rho0;
    f->grow = in->max_segment;
    f->substeps = (uint32_t)d->substeps;
    f->ncolliders = d->ncolliders;
    f->flags = (d->shape ? SIM_VK_FLAG_SHAPE : 0u) | (d->sph ? SIM_VK_FLAG_SPH : 0u) |
               (d->collisions ? SIM_VK_FLAG_COLLISIONS : 0u);
    f->cap = (uint32_t)p->neighbor_cap;
    f->drag_keep = d->drag_keep;
    f->friction = d->friction;
    f->sph_keep = d->sph_keep;
    f->sph_inv_since = d->sph_inv_since;
    f->hair_friction = d->hair_friction;
    f->ftl_damp = d->ftl_damp;
    if (d->sdf) {
        f->sdf_dims[0] = d->sdf->dims[0], f->sdf_dims[1] = d->sdf->dims[1], f->sdf_dims[2] = d->sdf->dims[2];
        f->sdf_dims[3] = 1u;
        put4(f->sdf_origin, d->sdf->origin.x, d->sdf->origin.y, d->sdf->origin.z, d->sdf->cell);
    }
    for (int k = 0; k < d->substeps; k++) {
        put4(f->head[k].pos, d->head[k].pos.x, d->head[k].pos.y, d->head[k].pos.z, 0.0f);
        put4(f->head[k].rot, d->head[k].rot.x, d->head[k].rot.y, d->head[k].rot.z, d->head[k].rot.w);
        for (uint32_t c = 0; c < f->ncolliders; c++) pack_collider(&d->col[k][c], &f->col[(size_t)k * SIM_MAX_COLLIDERS + c]);
        sim_vk_gsub *u = &f->sub[k];
        const sim_wsdf *w = &d->wsdf[k];
        for (int i = 0; i < 3; i++) {
            memcpy(u->carry[i], d->carry[k] + 4 * i, 4 * sizeof(float));
            put4(u->to_head[i], w->to_head[3 * i], w->to_head[3 * i + 1], w->to_head[3 * i + 2], 0.0f);
            put4(u->from_head[i], w->from_head[3 * i], w->from_head[3 * i + 1], w->from_head[3 * i + 2], 0.0f);
        }
        put4(u->pos, w->pos[0], w->pos[1], w->pos[2], 0.0f);
        put4(u->lo, w->lo[0], w->lo[1], w->lo[2], 0.0f);
        put4(u->hi, w->hi[0], w->hi[1], w->hi[2], 0.0f);
    }
    sim_shape_weights *sw = (sim_shape_weights *)((char *)out + sizeof *f);
    if (in->pbd) {
        const float b = sim_step_shape_damping(d->h);
        for (uint32_t l = 0; l < in->nv; l++) {
            sim_pbd_stiffness(p, l, in->nv, &sw[l].g, &sw[l].gd);
            sw[l].l = b;
            sw[l].ld = 0.0f;
        }
        return;
    }
    for (uint32_t l = 0; l < in->nv; l++) sim_step_stiffness(p, l, in->nv, &sw[l]);
}
