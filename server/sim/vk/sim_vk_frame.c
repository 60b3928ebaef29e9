/* sim_vk: the host-computed per-step parameters (substep heads, world colliders, constants). */
#include <stddef.h>
#include <string.h>

#include "sim_vk_internal.h"

_Static_assert(offsetof(sim_vk_frame, substeps) == 64, "frame layout must match sim_common.glsl");
_Static_assert(offsetof(sim_vk_frame, head) == 80, "frame layout must match sim_common.glsl");
_Static_assert(offsetof(sim_vk_frame, col) == 80 + 32 * SIM_VK_MAX_SUBSTEPS, "frame layout must match sim_common.glsl");
_Static_assert(sizeof(sim_vk_gcollider) == 160, "collider layout must match sim_common.glsl");
_Static_assert(sizeof(sim_vk_frame) % 8 == 0, "stiffness pairs follow the frame");

size_t sim_vk_frame_size(uint32_t nv) { return sizeof(sim_vk_frame) + (size_t)nv * 2 * sizeof(float); }

static void put4(float *dst, float x, float y, float z, float w)
{
    dst[0] = x, dst[1] = y, dst[2] = z, dst[3] = w;
}

#define MAXF(a, b) ((a) > (b) ? (a) : (b))
#define MINF(a, b) ((a) < (b) ? (a) : (b))

void sim_vk_world_collider(const core_collider *in, core_xform head, sim_vk_gcollider *out)
{
    memset(out, 0, sizeof *out);
    core_vec3 a = core_xform_point(head, in->a), b = core_xform_point(head, in->b);
    core_quat rot = core_q_norm(core_q_mul(head.rot, in->rot));
    put4(out->a, a.x, a.y, a.z, (float)in->kind);
    put4(out->b, b.x, b.y, b.z, in->radius);
    core_vec3 ax[3] = { core_q_rotate(rot, core_v3(1, 0, 0)), core_q_rotate(rot, core_v3(0, 1, 0)),
                        core_q_rotate(rot, core_v3(0, 0, 1)) }; /* columns of R */
    const float rad[3] = { in->radii.x, in->radii.y, in->radii.z };
    for (int i = 0; i < 3; i++) {
        const float col[3] = { ax[i].x, ax[i].y, ax[i].z };
        for (int j = 0; j < 3; j++) {
            out->m[i][j] = rad[i] > 0.0f ? col[j] / rad[i] : 0.0f; /* row i = axis i / r_i */
            out->nrm[j][i] = col[j] * rad[i];                     /* column i = axis i * r_i */
        }
    }
    float r = in->radius;
    if (in->kind == CORE_COLLIDER_ELLIPSOID) r = MAXF(in->radii.x, MAXF(in->radii.y, in->radii.z));
    core_vec3 e = in->kind == CORE_COLLIDER_CAPSULE ? b : a;
    put4(out->lo, MINF(a.x, e.x) - r, MINF(a.y, e.y) - r, MINF(a.z, e.z) - r, 0.0f);
    put4(out->hi, MAXF(a.x, e.x) + r, MAXF(a.y, e.y) + r, MAXF(a.z, e.z) + r, 0.0f);
}

void sim_vk_frame_fill(const sim_vk_frame_in *in, void *out)
{
    const sim_params *p = in->params;
    sim_vk_frame *f = out;
    memset(f, 0, sizeof *f);
    const int K = p->substeps;
    const float dt = p->dt, dt_k = dt / (float)K, h = p->sph_radius;
    put4(f->accel, p->wind_x, p->wind_y - p->gravity, p->wind_z, 0.0f);
    f->dt_k = dt_k;
    f->inv_dt_k = 1.0f / dt_k;
    f->damping = p->damping;
    f->h = h;
    f->h2 = h * h;
    f->inv_h2 = 1.0f / f->h2;
    f->inv_h = 1.0f / h;
    f->kp = p->repulsion * h * 3600.0f;
    f->mu_dt = p->viscosity * dt;
    f->inv_step_dt = 1.0f / dt;
    f->inv_rho0 = 1.0f / (p->rest_density * in->rho_rest);
    f->grow = in->max_segment;
    f->substeps = (uint32_t)K;
    f->ncolliders = p->collisions ? in->ncolliders : 0;
    f->flags = (p->shape ? SIM_VK_FLAG_SHAPE : 0u) | (in->sph ? SIM_VK_FLAG_SPH : 0u) |
               (p->collisions ? SIM_VK_FLAG_COLLISIONS : 0u);
    f->cap = (uint32_t)p->neighbor_cap;
    for (int k = 0; k < K && k < SIM_VK_MAX_SUBSTEPS; k++) {
        core_xform hk = core_xform_lerp(in->prev_head, in->head, (float)(k + 1) / (float)K);
        put4(f->head[k].pos, hk.pos.x, hk.pos.y, hk.pos.z, 0.0f);
        put4(f->head[k].rot, hk.rot.x, hk.rot.y, hk.rot.z, hk.rot.w);
        for (uint32_t c = 0; c < f->ncolliders; c++)
            sim_vk_world_collider(&in->colliders[c], hk, &f->col[(size_t)k * SIM_VK_MAX_COLLIDERS + c]);
    }
    float *stiff = (float *)((char *)out + sizeof *f);
    for (uint32_t l = 0; l < in->nv; l++) {
        float t = (float)l / (float)(in->nv - 1);
        float fade = 1.0f + (p->stiffness_tip - 1.0f) * t;
        stiff[2 * l] = p->shape ? p->global_stiffness * fade : 0.0f;
        stiff[2 * l + 1] = p->shape ? p->local_stiffness * fade : 0.0f;
    }
}
