/* sim: the CPU reference backend: state, parameters and the step sequence (Algorithm 1). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sim_cpu.h"
#include "sim_cpu_internal.h"
#include "sim_mem.h"
#include "sim_order.h"

static void update_stiffness(sim_cpu *c)
{
    for (uint32_t l = 0; l < c->nv; l++) sim_step_stiffness(&c->params, l, c->nv, &c->sw[l]);
}

static void keep_eval_positions(sim_cpu *c);

static void cpu_reset(void *self)
{
    sim_cpu *c = self;
    for (size_t i = 0; i < c->n; i++) {
        core_vec3 p = core_xform_point(c->head, core_v3(c->rest[0][i], c->rest[1][i], c->rest[2][i]));
        c->x[0][i] = p.x, c->x[1][i] = p.y, c->x[2][i] = p.z;
        c->v[0][i] = c->v[1][i] = c->v[2][i] = 0.0f;
        c->a[0][i] = c->a[1][i] = c->a[2][i] = 0.0f;
    }
    memset(c->af, 0, 4 * c->n * sizeof *c->af);
    keep_eval_positions(c);
    c->prev_head = c->head;
    c->sph.lists_valid = false;
    c->sph_clock = (sim_sph_clock){ 0 };
    memset(c->nan_per_thread, 0, sizeof c->nan_per_thread);
    c->stats.steps = 0;
    c->stats.sim_time = 0.0;
    c->stats.nan_resets = 0;
    c->stats.sph_passes = 0;
    c->stats.sph_searches = 0;
}

static void cpu_destroy(void *self)
{
    sim_cpu *c = self;
    if (!c) return;
    sim_pool_destroy(&c->pool);
    sim_cpu_sph_free(&c->sph);
    for (int k = 0; k < 3; k++) {
        free(c->x[k]);
        free(c->v[k]);
        free(c->a[k]);
        free(c->rest[k]);
        free(c->xe[k]);
        free(c->saved_xe[k]);
        free(c->saved_x[k]);
        free(c->saved_v[k]);
        free(c->saved_a[k]);
    }
    free(c->af);
    free(c->saved_af);
    free(c->sw);
    free(c->perm);
    core_sdf_free(&c->sdf);
    free(c);
}

static core_status cpu_set_params(void *self, const sim_params *p, core_err *err)
{
    (void)err;
    sim_cpu *c = self;
    if (p->sph_radius != c->params.sph_radius || p->neighbor_cap != c->params.neighbor_cap) {
        c->rho_rest_valid = false;
        c->sph.lists_valid = false;
    }
    c->params = *p;
    update_stiffness(c);
    return CORE_OK;
}

/* The mean SPH density of the rest pose (the reference rest_density scales), once per groom and
 * smoothing length; c->step must be planned with the current parameters. */
static core_status rest_density(sim_cpu *c, core_err *err)
{
    if (c->rho_rest_valid) return CORE_OK;
    double mean;
    core_status st = sim_cpu_sph_pass(c, c->rest, NULL, 0.0f, c->params.dt, core_xform_identity(), &mean, false, err);
    if (st != CORE_OK) return st;
    c->rho_rest = (float)mean;
    c->rho_rest_valid = true;
    return CORE_OK;
}

static core_status cpu_create(const sim_desc *desc, const core_groom *g, const sim_params *params, void **out,
                              core_err *err)
{
    *out = NULL;
    core_status gst = sim_groom_check(g, err);
    if (gst != CORE_OK) return gst;
    const size_t n = (size_t)g->nstrands * g->nverts, bytes = n * sizeof(float);
    sim_cpu *c = calloc(1, sizeof *c);
    if (!c) return core_fail(err, CORE_ENOMEM, "out of memory");
    c->ns = g->nstrands;
    c->nv = g->nverts;
    c->n = n;
    c->head = c->prev_head = core_xform_identity();
    c->ncolliders = g->ncolliders;
    memcpy(c->colliders, g->colliders, sizeof c->colliders);
    bool ok = true;
    for (int k = 0; k < 3; k++) {
        c->x[k] = sim_mem_alloc(bytes, false);
        c->v[k] = sim_mem_alloc(bytes, false);
        c->a[k] = sim_mem_alloc(bytes, false);
        c->rest[k] = sim_mem_alloc(bytes, false);
        c->xe[k] = sim_mem_alloc(bytes, false);
        ok = ok && c->x[k] && c->v[k] && c->a[k] && c->rest[k] && c->xe[k];
    }
    c->af = sim_mem_alloc(4 * bytes, true);
    ok = ok && c->af;
    c->sw = malloc(c->nv * sizeof *c->sw);
    if (!ok || !c->sw || sim_strand_order(g, &c->perm, err) != CORE_OK) {
        cpu_destroy(c);
        return core_fail(err, CORE_ENOMEM, "out of memory for %zu particles", n);
    }
    for (uint32_t s = 0; s < c->ns; s++)
        for (uint32_t l = 0; l < c->nv; l++)
            for (int k = 0; k < 3; k++)
                c->rest[k][(size_t)l * c->ns + s] = g->pos[3 * ((size_t)c->perm[s] * c->nv + l) + k];
    c->max_segment = sim_groom_max_segment(g);
    if (g->sdf) {
        core_status sst = core_sdf_copy(&c->sdf, g->sdf, err);
        if (sst != CORE_OK) {
            cpu_destroy(c);
            return sst;
        }
    }
    c->sph_auto_h = sim_sph_auto_radius(g);
    c->sph.portable = desc && desc->portable;
    core_status st = sim_pool_init(&c->pool, desc ? desc->threads : 0, err);
    if (st != CORE_OK) {
        cpu_destroy(c);
        return st;
    }
    c->params = *params;
    update_stiffness(c);
    cpu_reset(c);
    /* the rest density now, not in the first step: whoever creates the sim (the daemon's loader
     * thread on a groom change) pays for it, not the first step's frame */
    const sim_groom_info gi = { c->ncolliders, c->colliders, c->sdf.d ? &c->sdf : NULL, 1.0f, c->sph_auto_h };
    sim_step_plan(&c->params, &gi, c->head, c->head, &c->step);
    if (c->step.sph && (st = rest_density(c, err)) != CORE_OK) {
        cpu_destroy(c);
        return st;
    }
    *out = c;
    return CORE_OK;
}

static void cpu_set_motion(void *self, core_xform head)
{
    sim_cpu *c = self;
    head.rot = core_q_norm(head.rot);
    c->head = head;
}

static void cpu_set_cancel(void *self, sim_cancel_fn poll, void *ctx)
{
    sim_cpu *c = self;
    c->cancel = poll;
    c->cancel_ctx = ctx;
}

/* Slices of each state array a copy task takes (whichever worker is free). */
#define COPY_PARTS 8

/* The state arrays x, v, a, xe and af (16 of n floats, af's 4 n as four) copied from src to dst
 * by the pool's workers: a cancellable step (the daemon's) copies the whole state, 64 bytes a
 * particle, before it starts. */
typedef struct copy_ctx {
    float *const *dst, *const *src;
    size_t n;
} copy_ctx;

static void copy_task(void *vctx, size_t task, size_t ntasks, int worker)
{
    (void)ntasks, (void)worker;
    const copy_ctx *k = vctx;
    size_t b, e;
    sim_pool_range(k->n, (int)(task % COPY_PARTS), COPY_PARTS, 16, &b, &e);
    memcpy(k->dst[task / COPY_PARTS] + b, k->src[task / COPY_PARTS] + b, (e - b) * sizeof(float));
}

/* The positions the next SPH evaluation measures the hair's motion from (xe) are the current
 * ones (copied by the pool's workers: 12 bytes a particle at every evaluation). */
static void keep_eval_positions(sim_cpu *c)
{
    copy_ctx k = { c->xe, c->x, c->n };
    sim_pool_run_tasks(&c->pool, copy_task, &k, 3 * COPY_PARTS);
}

/* Copies the state (x, v, a, xe, af) into the saved copies, or back with restore. */
static void copy_state(sim_cpu *c, bool restore)
{
    const size_t n = c->n;
    float *const live[16] = { c->x[0], c->x[1], c->x[2], c->v[0], c->v[1], c->v[2], c->a[0], c->a[1],
                              c->a[2], c->xe[0], c->xe[1], c->xe[2], c->af, c->af + n, c->af + 2 * n, c->af + 3 * n };
    float *const saved[16] = { c->saved_x[0], c->saved_x[1], c->saved_x[2], c->saved_v[0], c->saved_v[1], c->saved_v[2],
                               c->saved_a[0], c->saved_a[1], c->saved_a[2], c->saved_xe[0], c->saved_xe[1], c->saved_xe[2],
                               c->saved_af, c->saved_af + n, c->saved_af + 2 * n, c->saved_af + 3 * n };
    copy_ctx k = { restore ? live : saved, restore ? saved : live, n };
    sim_pool_run_tasks(&c->pool, copy_task, &k, 16 * COPY_PARTS);
}

/* Before the step changes anything: the copies a cancelled step goes back to. false when they
 * cannot be allocated (the step then runs without the option of abandoning it). */
static bool save_state(sim_cpu *c)
{
    for (int k = 0; k < 3; k++) {
        float **bufs[4] = { &c->saved_x[k], &c->saved_v[k], &c->saved_a[k], &c->saved_xe[k] };
        for (int b = 0; b < 4; b++)
            if (!*bufs[b] && !(*bufs[b] = sim_mem_alloc(c->n * sizeof(float), false))) return false;
    }
    if (!c->saved_af && !(c->saved_af = sim_mem_alloc(4 * c->n * sizeof(float), false))) return false;
    copy_state(c, false);
    c->saved_clock = c->sph_clock;
    memcpy(c->saved_nan, c->nan_per_thread, sizeof c->saved_nan);
    return true;
}

/* Abandons the step in progress: back to the state save_state kept. The SPH lists stay as the
 * step's pass left them: built from the positions the step began with (or kept), exactly what
 * the pass of the step taken again decides from the same positions, so no later step differs. */
static core_status cancel_step(sim_cpu *c, core_err *err)
{
    copy_state(c, true);
    c->sph_clock = c->saved_clock;
    memcpy(c->nan_per_thread, c->saved_nan, sizeof c->saved_nan);
    return core_fail(err, CORE_ECANCELED, "step abandoned on request");
}

static core_status cpu_step(void *self, core_err *err)
{
    sim_cpu *c = self;
    if (c->cancel && c->cancel(c->cancel_ctx)) return core_fail(err, CORE_ECANCELED, "step abandoned on request");
    const bool cancellable = c->cancel && save_state(c);
    unsigned long long t0 = core_now_ns(), t1 = t0;
    const float dt = c->params.dt;
    const sim_groom_info gi = { c->ncolliders, c->colliders, c->sdf.d ? &c->sdf : NULL,
                                c->rho_rest_valid ? c->rho_rest : 1.0f, c->sph_auto_h };
    sim_step_plan(&c->params, &gi, c->prev_head, c->head, &c->step);
    sim_step_sph_clock(&c->params, &c->sph_clock, &c->step);
    if (c->step.sph_eval) {
        core_status st = rest_density(c, err);
        if (st != CORE_OK) return st;
        c->step.inv_rho0 = 1.0f / (c->params.rest_density * c->rho_rest);
        st = sim_cpu_sph_pass(c, c->x, c->xe, c->step.sph_inv_since, dt, c->prev_head, NULL, cancellable, err);
        if (st == CORE_ECANCELED) return cancel_step(c, err);
        if (st != CORE_OK) return st;
        keep_eval_positions(c);
        t1 = core_now_ns();
        if (cancellable && c->cancel(c->cancel_ctx)) return cancel_step(c, err);
    }
    for (int k = 0; k < c->step.substeps; k++) {
        if (k > 0 && cancellable && c->cancel(c->cancel_ctx)) return cancel_step(c, err);
        sim_cpu_chain_pass(c, k);
    }
    c->prev_head = c->head;
    unsigned long long t2 = core_now_ns();
    uint64_t nan = 0;
    for (int t = 0; t < c->pool.nthreads; t++) nan += c->nan_per_thread[t];
    c->stats.nan_resets = nan;
    c->stats.steps++;
    c->stats.sim_time += dt;
    c->stats.last_step_ms = (double)(t2 - t0) * 1e-6;
    c->stats.nstages = 2;
    c->stats.stage_names[0] = "sph";
    c->stats.stage_ms[0] = (double)(t1 - t0) * 1e-6;
    c->stats.stage_names[1] = "dftl";
    c->stats.stage_ms[1] = (double)(t2 - t1) * 1e-6;
    return CORE_OK;
}

typedef struct read_ctx {
    const sim_cpu *c;
    float *xyz, *vel;
} read_ctx;

/* Strand-major copies of 64 strands (one task) of the level-major state. */
static void read_task(void *vctx, size_t task, size_t ntasks, int worker)
{
    (void)ntasks, (void)worker;
    const read_ctx *r = vctx;
    const sim_cpu *c = r->c;
    const uint32_t s0 = (uint32_t)task * 64, s1 = s0 + 64 < c->ns ? s0 + 64 : c->ns;
    float *const outs[2] = { r->xyz, r->vel };
    const float *const *ins[2] = { (const float *const *)c->x, (const float *const *)c->v };
    for (int a = 0; a < 2; a++) {
        float *out = outs[a];
        if (!out) continue;
        const float *const *in = ins[a];
        for (uint32_t s = s0; s < s1; s++) {
            float *o = out + 3 * (size_t)c->perm[s] * c->nv;
            for (uint32_t l = 0; l < c->nv; l++) {
                const size_t i = (size_t)l * c->ns + s;
                o[3 * l] = in[0][i], o[3 * l + 1] = in[1][i], o[3 * l + 2] = in[2][i];
            }
        }
    }
}

static core_status cpu_read_state(void *self, float *xyz, float *vel, core_err *err)
{
    (void)err;
    sim_cpu *c = self;
    read_ctx r = { c, xyz, vel };
    sim_pool_run_tasks(&c->pool, read_task, &r, (c->ns + 63) / 64);
    return CORE_OK;
}

static core_status cpu_read_positions(void *self, float *xyz, core_err *err)
{
    return cpu_read_state(self, xyz, NULL, err);
}

static core_status cpu_write_state(void *self, const float *xyz, const float *vel, core_err *err)
{
    sim_cpu *c = self;
    for (size_t i = 0; i < 3 * c->n; i++)
        if (!isfinite(xyz[i]) || (vel && !isfinite(vel[i])))
            return core_fail(err, CORE_EINVAL, "state value %zu is not finite", i);
    for (uint32_t s = 0; s < c->ns; s++)
        for (uint32_t l = 0; l < c->nv; l++) {
            size_t i = (size_t)l * c->ns + s, o = 3 * ((size_t)c->perm[s] * c->nv + l);
            for (int k = 0; k < 3; k++) {
                c->x[k][i] = xyz[o + k];
                c->v[k][i] = vel ? vel[o + k] : 0.0f;
            }
        }
    c->sph.lists_valid = false;
    return CORE_OK;
}

static void cpu_get_stats(void *self, sim_stats *out)
{
    sim_cpu *c = self;
    *out = c->stats;
}

static const sim_vtable cpu_vtable = {
    .name = "cpu",
    .create = cpu_create,
    .set_params = cpu_set_params,
    .set_motion = cpu_set_motion,
    .step = cpu_step,
    .read_positions = cpu_read_positions,
    .write_state = cpu_write_state,
    .read_state = cpu_read_state,
    .reset = cpu_reset,
    .get_stats = cpu_get_stats,
    .destroy = cpu_destroy,
    .set_cancel = cpu_set_cancel,
};

const sim_vtable *sim_cpu_vtable(void) { return &cpu_vtable; }
