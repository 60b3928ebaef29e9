/* sim: the PBD guide-strand solver on the CPU: state, parameters, the step sequence and state
 * copies (the constraints are in sim_pbd_solve.c). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sim_pbd.h"
#include "sim_pbd_internal.h"

void sim_pbd_stiffness(const sim_params *p, uint32_t l, uint32_t nv, float *kg, float *kl)
{
    const float t = nv > 1 ? (float)l / (float)(nv - 1) : 0.0f;
    const float fade = p->shape ? 1.0f + (p->stiffness_tip - 1.0f) * t : 0.0f;
    *kg = p->global_stiffness * fade;
    *kl = p->local_stiffness * fade;
}

static void update_stiffness(sim_pbd *p)
{
    for (uint32_t l = 0; l < p->nv; l++) sim_pbd_stiffness(&p->params, l, p->nv, &p->kg[l], &p->kl[l]);
}

void sim_pbd_restore_strand(sim_pbd *p, uint32_t s, core_xform head)
{
    for (uint32_t l = 0; l < p->nv; l++) {
        const size_t i = 3 * ((size_t)s * p->nv + l);
        const core_vec3 q = core_xform_point(head, core_v3(p->rest[i], p->rest[i + 1], p->rest[i + 2]));
        p->x[i] = q.x, p->x[i + 1] = q.y, p->x[i + 2] = q.z;
        p->v[i] = p->v[i + 1] = p->v[i + 2] = 0.0f;
    }
}

static void pbd_reset(void *self)
{
    sim_pbd *p = self;
    for (uint32_t s = 0; s < p->ns; s++) sim_pbd_restore_strand(p, s, p->head);
    p->prev_head = p->head;
    memset(p->nan_per_worker, 0, sizeof p->nan_per_worker);
    memset(p->stretch_per_worker, 0, sizeof p->stretch_per_worker);
    memset(p->stretch_sum_per_worker, 0, sizeof p->stretch_sum_per_worker);
    p->stretch_segments = 0;
    p->stats.pbd_stretch_mean = 0.0;
    p->stats.pbd_stretch_max = 0.0;
    p->stats.steps = 0;
    p->stats.sim_time = 0.0;
    p->stats.nan_resets = 0;
}

static void pbd_destroy(void *self)
{
    sim_pbd *p = self;
    if (!p) return;
    sim_pool_destroy(&p->pool);
    free(p->x);
    free(p->v);
    free(p->start);
    free(p->rest);
    free(p->len);
    free(p->contact_floor);
    free(p->kg);
    free(p->kl);
    free(p->scratch);
    core_sdf_free(&p->sdf);
    free(p);
}

static core_status pbd_set_params(void *self, const sim_params *params, core_err *err)
{
    (void)err;
    sim_pbd *p = self;
    p->params = *params;
    update_stiffness(p);
    return CORE_OK;
}

static core_status pbd_create(const sim_desc *desc, const core_groom *g, const sim_params *params, void **out,
                              core_err *err)
{
    *out = NULL;
    core_status st = sim_groom_check(g, err);
    if (st != CORE_OK) return st;
    const size_t n = (size_t)g->nstrands * g->nverts, bytes = 3 * n * sizeof(float);
    sim_pbd *p = calloc(1, sizeof *p);
    if (!p) return core_fail(err, CORE_ENOMEM, "out of memory");
    p->ns = g->nstrands;
    p->nv = g->nverts;
    p->n = n;
    p->head = p->prev_head = core_xform_identity();
    p->ncolliders = g->ncolliders;
    memcpy(p->colliders, g->colliders, sizeof p->colliders);
    p->x = malloc(bytes);
    p->v = malloc(bytes);
    p->start = malloc(bytes);
    p->rest = malloc(bytes);
    p->len = malloc(n * sizeof(float));
    p->contact_floor = malloc(n * sizeof(float));
    p->kg = malloc(p->nv * sizeof(float));
    p->kl = malloc(p->nv * sizeof(float));
    if (!p->x || !p->v || !p->start || !p->rest || !p->len || !p->contact_floor || !p->kg || !p->kl) {
        pbd_destroy(p);
        return core_fail(err, CORE_ENOMEM, "out of memory for %zu particles", n);
    }
    memcpy(p->rest, g->pos, bytes);
    for (size_t i = 0; i < n; i++) {
        const float *r = p->rest + 3 * i;
        p->len[i] = i % p->nv == 0 ? 0.0f : sqrtf((r[0] - r[-3]) * (r[0] - r[-3]) + (r[1] - r[-2]) * (r[1] - r[-2]) +
                                                 (r[2] - r[-1]) * (r[2] - r[-1]));
    }
    sim_groom_contact_floor(g, p->contact_floor);
    if (g->sdf && (st = core_sdf_copy(&p->sdf, g->sdf, err)) != CORE_OK) {
        pbd_destroy(p);
        return st;
    }
    if ((st = sim_pool_init(&p->pool, desc ? desc->threads : 0, err)) != CORE_OK) {
        pbd_destroy(p);
        return st;
    }
    p->scratch = malloc((size_t)p->pool.nthreads * SIM_PBD_SCRATCH * p->nv * SIM_PBD_LANES * sizeof(float));
    if (!p->scratch) {
        pbd_destroy(p);
        return core_fail(err, CORE_ENOMEM, "out of memory for the solver's scratch");
    }
    p->params = *params;
    update_stiffness(p);
    pbd_reset(p);
    *out = p;
    return CORE_OK;
}

static void pbd_set_motion(void *self, core_xform head)
{
    sim_pbd *p = self;
    head.rot = core_q_norm(head.rot);
    p->head = head;
}

static core_status pbd_step(void *self, core_err *err)
{
    (void)err;
    sim_pbd *p = self;
    const unsigned long long t0 = core_now_ns();
    /* the SPH fields of the plan are not used by this solver */
    const sim_groom_info gi = { p->ncolliders, p->colliders, p->sdf.d ? &p->sdf : NULL, 1.0f, (float)SIM_SPH_FALLBACK_H };
    sim_step_plan(&p->params, &gi, p->prev_head, p->head, &p->step);
    for (int k = 0; k < p->step.substeps; k++) sim_pbd_substep(p, k);
    p->prev_head = p->head;
    p->stretch_segments += (uint64_t)p->step.substeps * p->ns * (p->nv - 1);
    uint64_t nan = 0, sum = 0;
    for (int t = 0; t < p->pool.nthreads; t++) {
        nan += p->nan_per_worker[t];
        sum += p->stretch_sum_per_worker[t];
        p->stats.pbd_stretch_max = fmax(p->stats.pbd_stretch_max, p->stretch_per_worker[t]);
    }
    p->stats.pbd_stretch_mean = (double)sum / SIM_PBD_STRETCH_UNIT / (double)p->stretch_segments;
    p->stats.nan_resets = nan;
    p->stats.steps++;
    p->stats.sim_time += p->params.dt;
    p->stats.last_step_ms = (double)(core_now_ns() - t0) * 1e-6;
    p->stats.nstages = 1;
    p->stats.stage_names[0] = "pbd";
    p->stats.stage_ms[0] = p->stats.last_step_ms;
    return CORE_OK;
}

static core_status pbd_read_state(void *self, float *xyz, float *vel, core_err *err)
{
    (void)err;
    const sim_pbd *p = self;
    if (xyz) memcpy(xyz, p->x, 3 * p->n * sizeof(float));
    if (vel) memcpy(vel, p->v, 3 * p->n * sizeof(float));
    return CORE_OK;
}

static core_status pbd_read_positions(void *self, float *xyz, core_err *err)
{
    return pbd_read_state(self, xyz, NULL, err);
}

static core_status pbd_write_state(void *self, const float *xyz, const float *vel, core_err *err)
{
    sim_pbd *p = self;
    for (size_t i = 0; i < 3 * p->n; i++)
        if (!isfinite(xyz[i]) || (vel && !isfinite(vel[i])))
            return core_fail(err, CORE_EINVAL, "state value %zu is not finite", i);
    memcpy(p->x, xyz, 3 * p->n * sizeof(float));
    if (vel) memcpy(p->v, vel, 3 * p->n * sizeof(float));
    else memset(p->v, 0, 3 * p->n * sizeof(float));
    return CORE_OK;
}

static void pbd_get_stats(void *self, sim_stats *out)
{
    const sim_pbd *p = self;
    *out = p->stats;
}

static const sim_vtable pbd_vtable = {
    .name = "cpu-pbd",
    .create = pbd_create,
    .set_params = pbd_set_params,
    .set_motion = pbd_set_motion,
    .step = pbd_step,
    .read_positions = pbd_read_positions,
    .write_state = pbd_write_state,
    .read_state = pbd_read_state,
    .reset = pbd_reset,
    .get_stats = pbd_get_stats,
    .destroy = pbd_destroy,
};

const sim_vtable *sim_pbd_vtable(void) { return &pbd_vtable; }
