/* sim_vk: the Vulkan backend's function table: create, parameters, step submission (the DFTL or
 * the PBD solver), state transfer. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sim_vk_internal.h"
#include "../sim_order.h"

static const char *const stage_names[SIM_VK_NSTAGES] = { "sph_grid", "sph_sort", "sph_density", "sph_force", "chain" };


/* Marks the instance unusable after a failed submit or wait; later calls return the error. */
static core_status fail_sticky(sim_vk *s, core_status st, const core_err *why)
{
    if (s->broken == CORE_OK) {
        s->broken = st;
        s->broken_err = *why;
        core_log(CORE_LOG_ERROR, "sim_vk", "%s", why->msg);
    }
    return st;
}

static core_status check_broken(sim_vk *s, core_err *err)
{
    if (s->broken == CORE_OK) return CORE_OK;
    return core_fail(err, s->broken, "%s", s->broken_err.msg);
}

/* Waits for slot i's step and takes its timestamps and counters. */
static core_status collect(sim_vk *s, int i, core_err *err)
{
    sim_vk_slot *sl = &s->slots[i];
    if (!sl->pending) return CORE_OK;
    core_status st = sim_vk_check(vkWaitForFences(s->ctx.device, 1, &sl->fence, VK_TRUE, UINT64_MAX),
                                  "vkWaitForFences(step)", err);
    if (st != CORE_OK) return fail_sticky(s, st, err);
    sl->pending = false;
    uint64_t ts[SIM_VK_NSTAGES + 1];
    if (sl->queries &&
        vkGetQueryPoolResults(s->ctx.device, sl->queries, 0, SIM_VK_NSTAGES + 1, sizeof ts, ts, sizeof ts[0],
                              VK_QUERY_RESULT_64_BIT) == VK_SUCCESS) {
        double period = s->ctx.props.limits.timestampPeriod * 1e-6; /* ms per tick */
        for (int k = 0; k < SIM_VK_NSTAGES; k++)
            s->stats.stage_ms[k] = (double)((ts[k + 1] - ts[k]) & s->ctx.timestamp_mask) * period;
        s->stats.last_step_ms = (double)((ts[SIM_VK_NSTAGES] - ts[0]) & s->ctx.timestamp_mask) * period;
    } else {
        s->stats.last_step_ms = (double)(core_now_ns() - sl->submit_ns) * 1e-6;
    }
    const uint32_t *counters = s->stats_buf.map;
    s->stats.nan_resets = counters[0];
    float stretch;
    memcpy(&stretch, &counters[1], sizeof stretch);
    s->stats.pbd_stretch_max = stretch;
    const uint64_t sum = (uint64_t)counters[3] << 32 | counters[2];
    s->stats.pbd_stretch_mean = s->pbd_segments ? (double)sum / SIM_PBD_STRETCH_UNIT / (double)s->pbd_segments : 0.0;
    return CORE_OK;
}

static core_status collect_all(sim_vk *s, core_err *err)
{
    for (int i = 0; i < SIM_VK_FRAMES; i++) {
        core_status st = collect(s, i, err);
        if (st != CORE_OK) return st;
    }
    return CORE_OK;
}

/* bytes for a buffer only the SPH passes use: a 16-byte placeholder (bound, never touched) on the
 * PBD solver, which has no SPH. */
static size_t sph_bytes(const sim_vk *s, size_t bytes) { return s->params.solver == SIM_SOLVER_PBD ? 16 : bytes; }

static core_status make_nbr(sim_vk *s, uint32_t cap, core_err *err)
{
    size_t bytes = 16;
    if (s->params.solver != SIM_SOLVER_PBD && !core_mul_size(s->n, (size_t)cap * sizeof(uint32_t), &bytes))
        return core_fail(err, CORE_ENOMEM, "vulkan: neighbour lists of %zu x %u are too large", s->n, cap);
    sim_vk_buf nb;
    core_status st = sim_vk_buf_create(&s->ctx, &nb, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, SIM_VK_MEM_DEVICE,
                                       "sph neighbours", err);
    if (st != CORE_OK) return st;
    sim_vk_buf_destroy(&s->ctx, &s->nbr);
    s->nbr = nb;
    s->nbr_cap = cap;
    sim_vk_pipes_bind(&s->ctx, &s->pipes, -1, SIM_VK_B_NBR, &s->nbr);
    return CORE_OK;
}

typedef struct buf_spec {
    sim_vk_buf *buf;
    size_t bytes;
    sim_vk_binding binding;
    VkBufferUsageFlags extra;
    const char *name;
} buf_spec;

static core_status make_buffers(sim_vk *s, core_err *err)
{
    const size_t n = s->n, p3 = n * 3 * sizeof(float), cells = s->cells_cap;
    const size_t blocks = (cells + SIM_VK_SCAN_BLOCK - 1) / SIM_VK_SCAN_BLOCK;
    const VkBufferUsageFlags xfer = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    const buf_spec specs[] = {
        { &s->x, p3, SIM_VK_B_X, xfer, "positions" },
        { &s->xe, sph_bytes(s, p3), SIM_VK_B_XE, xfer, "positions at the last sph evaluation" },
        { &s->v, p3, SIM_VK_B_V, xfer, "velocities" },
        { &s->a, sph_bytes(s, p3), SIM_VK_B_A, xfer, "sph accelerations" },
        { &s->af, sph_bytes(s, p3), SIM_VK_B_AF, xfer, "held hair-hair friction" },
        { &s->rest_buf, p3, SIM_VK_B_REST, xfer, "rest positions" },
        { &s->strand, (size_t)s->ns * 20 * sizeof(float), SIM_VK_B_STRAND, 0, "chain state" },
        { &s->grid, 128, SIM_VK_B_GRID, xfer, "sph grid" },
        { &s->count, sph_bytes(s, cells * sizeof(uint32_t)), SIM_VK_B_COUNT, xfer, "sph cell counts" },
        { &s->start, sph_bytes(s, (cells + 1) * sizeof(uint32_t)), SIM_VK_B_START, 0, "sph cell starts" },
        { &s->block, sph_bytes(s, blocks * sizeof(uint32_t)), SIM_VK_B_BLOCK, 0, "sph scan blocks" },
        { &s->cell_of, sph_bytes(s, n * sizeof(uint32_t)), SIM_VK_B_CELL_OF, 0, "sph particle cells" },
        { &s->order, sph_bytes(s, n * sizeof(uint32_t)), SIM_VK_B_ORDER, 0, "sph sorted order" },
        { &s->sx, sph_bytes(s, n * 4 * sizeof(float)), SIM_VK_B_SX, 0, "sph sorted positions" },
        { &s->sv, sph_bytes(s, n * 4 * sizeof(float)), SIM_VK_B_SV, 0, "sph sorted velocities" },
        { &s->rho, sph_bytes(s, n * sizeof(float)), SIM_VK_B_RHO, xfer, "sph density" },
        { &s->press, sph_bytes(s, n * sizeof(float)), SIM_VK_B_PRESS, 0, "sph pressure" },
        { &s->nnbr, sph_bytes(s, n * sizeof(uint32_t)), SIM_VK_B_NNBR, 0, "sph neighbour counts" },
        { &s->floor_buf, s->params.solver == SIM_SOLVER_PBD ? n * sizeof(float) : 16, SIM_VK_B_FLOOR, xfer, "contact floors" },
    };
    for (size_t i = 0; i < sizeof specs / sizeof specs[0]; i++) {
        core_status st = sim_vk_buf_create(&s->ctx, specs[i].buf, specs[i].bytes,
                                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | specs[i].extra, SIM_VK_MEM_DEVICE,
                                           specs[i].name, err);
        if (st != CORE_OK) return st;
        sim_vk_pipes_bind(&s->ctx, &s->pipes, -1, specs[i].binding, specs[i].buf);
    }
    core_status st = sim_vk_buf_create(&s->ctx, &s->stats_buf, 16, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                       SIM_VK_MEM_READBACK, "counters", err);
    if (st != CORE_OK) return st;
    sim_vk_pipes_bind(&s->ctx, &s->pipes, -1, SIM_VK_B_STATS, &s->stats_buf);
    st = sim_vk_buf_create(&s->ctx, &s->staging, 2 * p3, xfer, SIM_VK_MEM_READBACK, "staging", err);
    if (st != CORE_OK) return st;
    const size_t sdf_bytes = s->has_sdf ? (size_t)s->sdf.dims[0] * s->sdf.dims[1] * s->sdf.dims[2] * sizeof(float) : 16;
    st = sim_vk_buf_create(&s->ctx, &s->sdf_buf, sdf_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | xfer,
                           SIM_VK_MEM_DEVICE, "distance grid", err);
    if (st != CORE_OK) return st;
    sim_vk_pipes_bind(&s->ctx, &s->pipes, -1, SIM_VK_B_SDF, &s->sdf_buf);
    size_t pbd_bytes = 16;
    if (s->params.solver == SIM_SOLVER_PBD && !core_mul_size(p3, 10, &pbd_bytes))
        return core_fail(err, CORE_ENOMEM, "vulkan: the PBD scratch of %zu particles is too large", n);
    st = sim_vk_buf_create(&s->ctx, &s->pbd, pbd_bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, SIM_VK_MEM_DEVICE,
                           "pbd scratch", err);
    if (st != CORE_OK) return st;
    sim_vk_pipes_bind(&s->ctx, &s->pipes, -1, SIM_VK_B_PBD, &s->pbd);
    return make_nbr(s, (uint32_t)s->params.neighbor_cap, err);
}

static core_status make_slots(sim_vk *s, core_err *err)
{
    for (int i = 0; i < SIM_VK_FRAMES; i++) {
        sim_vk_slot *sl = &s->slots[i];
        VkCommandBufferAllocateInfo ai = {
            .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
            .commandPool = s->ctx.pool,
            .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
            .commandBufferCount = 1,
        };
        core_status st = sim_vk_check(vkAllocateCommandBuffers(s->ctx.device, &ai, &sl->cmd), "vkAllocateCommandBuffers", err);
        if (st != CORE_OK) return st;
        VkFenceCreateInfo fci = { .sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO };
        st = sim_vk_check(vkCreateFence(s->ctx.device, &fci, NULL, &sl->fence), "vkCreateFence", err);
        if (st != CORE_OK) return st;
        if (s->ctx.timestamps) {
            VkQueryPoolCreateInfo qci = {
                .sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
                .queryType = VK_QUERY_TYPE_TIMESTAMP,
                .queryCount = SIM_VK_NSTAGES + 1,
            };
            st = sim_vk_check(vkCreateQueryPool(s->ctx.device, &qci, NULL, &sl->queries), "vkCreateQueryPool", err);
            if (st != CORE_OK) return st;
            sim_vk_name(&s->ctx, VK_OBJECT_TYPE_QUERY_POOL, (uint64_t)sl->queries, "step timestamps");
        }
        st = sim_vk_buf_create(&s->ctx, &sl->frame, sim_vk_frame_size(s->nv), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                               SIM_VK_MEM_UPLOAD, i ? "frame parameters 1" : "frame parameters 0", err);
        if (st != CORE_OK) return st;
        sim_vk_pipes_bind(&s->ctx, &s->pipes, i, SIM_VK_B_FRAME, &sl->frame);
        sim_vk_name(&s->ctx, VK_OBJECT_TYPE_COMMAND_BUFFER, (uint64_t)(uintptr_t)sl->cmd, i ? "step commands 1" : "step commands 0");
        sim_vk_name(&s->ctx, VK_OBJECT_TYPE_FENCE, (uint64_t)sl->fence, i ? "step fence 1" : "step fence 0");
    }
    return CORE_OK;
}

static void vk_destroy(void *self)
{
    sim_vk *s = self;
    if (!s) return;
    if (s->ctx.device) {
        (void)vkDeviceWaitIdle(s->ctx.device);
        for (int i = 0; i < SIM_VK_FRAMES; i++) {
            sim_vk_slot *sl = &s->slots[i];
            sim_vk_buf_destroy(&s->ctx, &sl->frame);
            if (sl->queries) vkDestroyQueryPool(s->ctx.device, sl->queries, NULL);
            if (sl->fence) vkDestroyFence(s->ctx.device, sl->fence, NULL);
            if (sl->cmd) vkFreeCommandBuffers(s->ctx.device, s->ctx.pool, 1, &sl->cmd);
        }
        sim_vk_once_destroy(&s->ctx, &s->once);
        sim_vk_buf *bufs[] = { &s->x, &s->xe, &s->v, &s->a, &s->af, &s->rest_buf, &s->strand, &s->grid, &s->count, &s->start,
                               &s->block, &s->cell_of, &s->order, &s->sx, &s->sv, &s->rho, &s->press, &s->nbr,
                               &s->nnbr, &s->stats_buf, &s->staging, &s->sdf_buf, &s->pbd, &s->floor_buf };
        for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++) sim_vk_buf_destroy(&s->ctx, bufs[i]);
        sim_vk_pipes_destroy(&s->ctx, &s->pipes);
    }
    sim_vk_ctx_destroy(&s->ctx);
    free(s->rest);
    free(s->host_tmp);
    free(s->perm);
    free(s);
}

/* Level-major xyz in the GPU's strand order <-> strand-major xyz in the groom's order. */
static void to_strand_major(const sim_vk *s, const float *lm, float *sm)
{
    for (uint32_t st = 0; st < s->ns; st++)
        for (uint32_t l = 0; l < s->nv; l++) {
            size_t i = (size_t)l * s->ns + st, o = (size_t)s->perm[st] * s->nv + l;
            memcpy(sm + 3 * o, lm + 3 * i, 3 * sizeof(float));
        }
}

/* Groom order (sm) -> level-major in internal strand order (lm), k floats per vertex. */
static void to_level_major(const sim_vk *s, const float *sm, float *lm, size_t k)
{
    for (uint32_t st = 0; st < s->ns; st++)
        for (uint32_t l = 0; l < s->nv; l++) {
            size_t i = (size_t)l * s->ns + st, o = (size_t)s->perm[st] * s->nv + l;
            memcpy(lm + k * i, sm + k * o, k * sizeof(float));
        }
}

/* Uploads x and v (level-major, v may be NULL = zero); with fresh, also x as the positions of
 * the last SPH evaluation (no motion yet) and zero accelerations. Blocking. */
static core_status upload_state(sim_vk *s, const float *x, const float *v, bool fresh, core_err *err)
{
    core_status st = collect_all(s, err);
    if (st != CORE_OK) return st;
    const size_t p3 = s->n * 3 * sizeof(float);
    float *stage = s->staging.map;
    memcpy(stage, x, p3);
    if (v)
        memcpy(stage + 3 * s->n, v, p3);
    else
        memset(stage + 3 * s->n, 0, p3);
    st = sim_vk_once_begin(&s->ctx, &s->once, err);
    if (st != CORE_OK) return fail_sticky(s, st, err);
    VkBufferCopy cx = { 0, 0, p3 }, cv = { p3, 0, p3 };
    vkCmdCopyBuffer(s->once.cmd, s->staging.buf, s->x.buf, 1, &cx);
    if (fresh && s->params.solver != SIM_SOLVER_PBD) vkCmdCopyBuffer(s->once.cmd, s->staging.buf, s->xe.buf, 1, &cx);
    vkCmdCopyBuffer(s->once.cmd, s->staging.buf, s->v.buf, 1, &cv);
    if (fresh) vkCmdFillBuffer(s->once.cmd, s->a.buf, 0, VK_WHOLE_SIZE, 0u);
    if (fresh) vkCmdFillBuffer(s->once.cmd, s->af.buf, 0, VK_WHOLE_SIZE, 0u);
    st = sim_vk_once_submit_wait(&s->ctx, &s->once, err);
    if (st != CORE_OK) return fail_sticky(s, st, err);
    return CORE_OK;
}

/* Rest pose under the current head, zero velocity and acceleration. */
static core_status reset_state(sim_vk *s, core_err *err)
{
    for (size_t i = 0; i < s->n; i++) {
        core_vec3 p = core_xform_point(s->head, core_v3(s->rest[3 * i], s->rest[3 * i + 1], s->rest[3 * i + 2]));
        s->host_tmp[3 * i] = p.x, s->host_tmp[3 * i + 1] = p.y, s->host_tmp[3 * i + 2] = p.z;
    }
    core_status st = upload_state(s, s->host_tmp, NULL, true, err);
    if (st != CORE_OK) return st;
    s->prev_head = s->head;
    s->sph_clock = (sim_sph_clock){ 0 };
    memset(s->stats_buf.map, 0, 16);
    sim_stats zero;
    memset(&zero, 0, sizeof zero);
    s->stats = zero;
    s->pbd_segments = 0;
    return CORE_OK;
}

/* One-time (per h and cap) mean density of the rest pose, as the C backend computes it. */
static core_status compute_rho_rest(sim_vk *s, int slot, core_err *err)
{
    const sim_groom_info gi = { s->ncolliders, s->colliders, s->has_sdf ? &s->sdf : NULL, 1.0f, s->sph_auto_h };
    sim_step_plan(&s->params, &gi, s->prev_head, s->head, &s->step);
    s->step.sph = true;
    const sim_vk_frame_in in = { &s->params, &s->step, s->nv, s->max_segment, false };
    sim_vk_frame_fill(&in, s->slots[slot].frame.map);
    core_status st = sim_vk_once_begin(&s->ctx, &s->once, err);
    if (st != CORE_OK) return fail_sticky(s, st, err);
    sim_vk_record_sph(s, s->once.cmd, s->pipes.sets[slot], SIM_VK_SPH_REST, VK_NULL_HANDLE);
    VkBufferCopy c = { 0, 0, s->n * sizeof(float) };
    vkCmdCopyBuffer(s->once.cmd, s->rho.buf, s->staging.buf, 1, &c);
    st = sim_vk_once_submit_wait(&s->ctx, &s->once, err);
    if (st != CORE_OK) return fail_sticky(s, st, err);
    const float *rho = s->staging.map;
    double sum = 0.0; /* serial, in sorted order, as the C backend */
    for (size_t i = 0; i < s->n; i++) sum += rho[i];
    s->rho_rest = (float)(sum / (double)s->n);
    s->rho_rest_valid = true;
    return CORE_OK;
}

static core_status vk_step(void *self, core_err *err)
{
    sim_vk *s = self;
    core_status st = check_broken(s, err);
    if (st != CORE_OK) return st;
    unsigned long long t0 = core_now_ns();
    const int f = (int)(s->submitted % SIM_VK_FRAMES);
    sim_vk_slot *sl = &s->slots[f];
    st = collect(s, f, err);
    if (st != CORE_OK) return st;
    const bool pbd = s->params.solver == SIM_SOLVER_PBD;
    const bool sph = !pbd && sim_step_sph_on(&s->params);
    if (sph && !s->rho_rest_valid) {
        st = compute_rho_rest(s, f, err);
        if (st != CORE_OK) return st;
    }
    /* the PBD solver plans as the C one does (it uses none of the SPH fields) */
    const sim_groom_info gi = { s->ncolliders, s->colliders, s->has_sdf ? &s->sdf : NULL,
                                s->rho_rest_valid ? s->rho_rest : 1.0f,
                                pbd ? (float)SIM_SPH_FALLBACK_H : s->sph_auto_h };
    sim_step_plan(&s->params, &gi, s->prev_head, s->head, &s->step);
    if (!pbd) sim_step_sph_clock(&s->params, &s->sph_clock, &s->step);
    const sim_vk_frame_in in = { &s->params, &s->step, s->nv, s->max_segment, pbd };
    sim_vk_frame_fill(&in, sl->frame.map);

    VkCommandBuffer cmd = sl->cmd;
    st = sim_vk_check(vkResetCommandBuffer(cmd, 0), "vkResetCommandBuffer", err);
    VkCommandBufferBeginInfo bi = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
        .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
    };
    if (st == CORE_OK) st = sim_vk_check(vkBeginCommandBuffer(cmd, &bi), "vkBeginCommandBuffer", err);
    if (st != CORE_OK) return fail_sticky(s, st, err);
    if (sl->queries) {
        vkCmdResetQueryPool(cmd, sl->queries, 0, SIM_VK_NSTAGES + 1);
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, sl->queries, 0);
    }
    sim_vk_barrier(cmd); /* after the previous step and any transfer */
    if (!pbd && s->step.sph_eval) {
        sim_vk_record_sph(s, cmd, s->pipes.sets[f], SIM_VK_SPH_STEP, sl->queries);
    } else if (sl->queries) {
        for (uint32_t k = SIM_VK_S_GRID; k <= SIM_VK_S_FORCE; k++)
            vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, sl->queries, k + 1);
    }
    if (pbd)
        sim_vk_record_pbd(s, cmd, s->pipes.sets[f]);
    else
        sim_vk_record_chain(s, cmd, s->pipes.sets[f]);
    if (sl->queries) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, sl->queries, SIM_VK_S_CHAIN + 1);
    st = sim_vk_check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer", err);
    if (st == CORE_OK) st = sim_vk_check(vkResetFences(s->ctx.device, 1, &sl->fence), "vkResetFences", err);
    VkSubmitInfo si = { .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO, .commandBufferCount = 1, .pCommandBuffers = &cmd };
    if (st == CORE_OK) st = sim_vk_check(vkQueueSubmit(s->ctx.queue, 1, &si, sl->fence), "vkQueueSubmit(step)", err);
    if (st != CORE_OK) return fail_sticky(s, st, err);
    sl->pending = true;
    sl->submit_ns = t0;
    s->submitted++;
    s->prev_head = s->head;
    s->stats.steps++;
    s->stats.sim_time += s->params.dt;
    if (pbd) s->pbd_segments += (uint64_t)s->step.substeps * s->ns * (s->nv - 1);
    return CORE_OK;
}

/* Copies x (and v when vel) of the GPU state to the caller, strand-major. Blocking. */
static core_status read_back(sim_vk *s, float *xyz, float *vel, core_err *err)
{
    core_status st = check_broken(s, err);
    if (st != CORE_OK) return st;
    const size_t p3 = s->n * 3 * sizeof(float);
    st = sim_vk_once_begin(&s->ctx, &s->once, err);
    if (st != CORE_OK) return fail_sticky(s, st, err);
    VkBufferCopy cx = { 0, 0, p3 }, cv = { 0, p3, p3 };
    if (xyz) vkCmdCopyBuffer(s->once.cmd, s->x.buf, s->staging.buf, 1, &cx);
    if (vel) vkCmdCopyBuffer(s->once.cmd, s->v.buf, s->staging.buf, 1, &cv);
    st = sim_vk_once_submit_wait(&s->ctx, &s->once, err);
    if (st != CORE_OK) return fail_sticky(s, st, err);
    const float *stage = s->staging.map;
    if (xyz) to_strand_major(s, stage, xyz);
    if (vel) to_strand_major(s, stage + 3 * s->n, vel);
    return collect_all(s, err); /* done by now: the readback came after them */
}

static core_status vk_read_positions(void *self, float *xyz, core_err *err) { return read_back(self, xyz, NULL, err); }

static core_status vk_read_state(void *self, float *xyz, float *vel, core_err *err)
{
    return read_back(self, xyz, vel, err);
}

static core_status vk_write_state(void *self, const float *xyz, const float *vel, core_err *err)
{
    sim_vk *s = self;
    core_status st = check_broken(s, err);
    if (st != CORE_OK) return st;
    for (size_t i = 0; i < 3 * s->n; i++)
        if (!isfinite(xyz[i]) || (vel && !isfinite(vel[i])))
            return core_fail(err, CORE_EINVAL, "state value %zu is not finite", i);
    /* x goes through host_tmp, v through the second half of staging */
    float *vtmp = NULL;
    if (vel) {
        vtmp = malloc(s->n * 3 * sizeof(float));
        if (!vtmp) return core_fail(err, CORE_ENOMEM, "out of memory for %zu velocities", s->n);
        to_level_major(s, vel, vtmp, 3);
    }
    to_level_major(s, xyz, s->host_tmp, 3);
    st = upload_state(s, s->host_tmp, vtmp, false, err);
    free(vtmp);
    return st;
}

static void vk_reset(void *self)
{
    sim_vk *s = self;
    core_err err;
    if (s->broken == CORE_OK) (void)reset_state(s, &err); /* a failure is sticky: the next call reports it */
}

static void vk_set_motion(void *self, core_xform head)
{
    sim_vk *s = self;
    head.rot = core_q_norm(head.rot);
    s->head = head;
}

static core_status vk_set_params(void *self, const sim_params *p, core_err *err)
{
    sim_vk *s = self;
    core_status st = check_broken(s, err);
    if (st != CORE_OK) return st;
    if (p->substeps < 1 || p->substeps > SIM_MAX_SUBSTEPS || p->neighbor_cap < 1 ||
        p->neighbor_cap > SIM_MAX_NEIGHBOR_CAP)
        return core_fail(err, CORE_EINVAL, "vulkan: substeps must be in [1, %d] and neighbor_cap in [1, %d]",
                         SIM_MAX_SUBSTEPS, SIM_MAX_NEIGHBOR_CAP);
    if ((uint32_t)p->neighbor_cap > s->nbr_cap) {
        st = collect_all(s, err);
        if (st == CORE_OK) st = make_nbr(s, (uint32_t)p->neighbor_cap, err);
        if (st != CORE_OK) return st;
    }
    if (p->sph_radius != s->params.sph_radius || p->neighbor_cap != s->params.neighbor_cap) s->rho_rest_valid = false;
    s->params = *p;
    return CORE_OK;
}

static void vk_get_stats(void *self, sim_stats *out)
{
    sim_vk *s = self;
    core_err err;
    (void)collect_all(s, &err); /* a failure is sticky: the next call reports it */
    *out = s->stats;
    out->nstages = SIM_VK_NSTAGES;
    for (int k = 0; k < SIM_VK_NSTAGES; k++) out->stage_names[k] = stage_names[k];
    if (s->params.solver == SIM_SOLVER_PBD) { /* the SPH stages are empty: one stage, the C backend's name */
        out->nstages = 1;
        out->stage_names[0] = "pbd";
        out->stage_ms[0] = s->stats.stage_ms[SIM_VK_S_CHAIN];
    }
    if (!s->ctx.timestamps) out->nstages = 0;
    out->device_bytes = s->ctx.buffer_bytes;
}

/* Copies the distance samples to sdf_buf through a temporary upload buffer. Blocking. */
static core_status upload_sdf(sim_vk *s, const core_sdf *sdf, core_err *err)
{
    const size_t bytes = (size_t)sdf->dims[0] * sdf->dims[1] * sdf->dims[2] * sizeof(float);
    sim_vk_buf up;
    core_status st = sim_vk_buf_create(&s->ctx, &up, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, SIM_VK_MEM_UPLOAD,
                                       "distance grid upload", err);
    if (st != CORE_OK) return st;
    memcpy(up.map, sdf->d, bytes);
    st = sim_vk_once_begin(&s->ctx, &s->once, err);
    if (st == CORE_OK) {
        VkBufferCopy c = { 0, 0, bytes };
        vkCmdCopyBuffer(s->once.cmd, up.buf, s->sdf_buf.buf, 1, &c);
        st = sim_vk_once_submit_wait(&s->ctx, &s->once, err);
    }
    sim_vk_buf_destroy(&s->ctx, &up);
    return st;
}

static core_status create_impl(const sim_desc *desc, const sim_vk_options *opt, const core_groom *g,
                               const sim_params *params, sim_vk **out, core_err *err)
{
    *out = NULL;
    core_status st = sim_groom_check(g, err);
    if (st != CORE_OK) return st;
    if (params->substeps < 1 || params->substeps > SIM_MAX_SUBSTEPS || params->neighbor_cap < 1 ||
        params->neighbor_cap > SIM_MAX_NEIGHBOR_CAP)
        return core_fail(err, CORE_EINVAL, "vulkan: substeps must be in [1, %d] and neighbor_cap in [1, %d]",
                         SIM_MAX_SUBSTEPS, SIM_MAX_NEIGHBOR_CAP);
    sim_vk *s = calloc(1, sizeof *s);
    if (!s) return core_fail(err, CORE_ENOMEM, "out of memory");
    s->ns = g->nstrands;
    s->nv = g->nverts;
    s->n = (size_t)g->nstrands * g->nverts;
    s->params = *params;
    s->head = s->prev_head = core_xform_identity();
    s->ncolliders = g->ncolliders;
    memcpy(s->colliders, g->colliders, sizeof s->colliders);
    /* hash buckets: a power of two >= 2n (at least 4096), as the C backend */
    s->cells_cap = 4096;
    while (s->cells_cap < 2 * s->n) s->cells_cap *= 2;
    s->rest = malloc(s->n * 3 * sizeof(float));
    s->host_tmp = malloc(s->n * 3 * sizeof(float));
    if (!s->rest || !s->host_tmp) {
        vk_destroy(s);
        return core_fail(err, CORE_ENOMEM, "out of memory for %zu particles", s->n);
    }
    st = sim_strand_order(g, &s->perm, err);
    if (st != CORE_OK) {
        vk_destroy(s);
        return st;
    }
    to_level_major(s, g->pos, s->rest, 3);
    s->max_segment = sim_groom_max_segment(g);
    if (g->sdf) { /* the header only: the samples go to the device below */
        s->has_sdf = true;
        memcpy(s->sdf.dims, g->sdf->dims, sizeof s->sdf.dims);
        s->sdf.origin = g->sdf->origin;
        s->sdf.cell = g->sdf->cell;
    }
    s->sph_auto_h = sim_sph_auto_radius(g);
    /* Debug builds always validate */
    bool validation = opt && opt->validation;
#ifdef STRANDCAST_VK_DEBUG
    validation = true;
#endif
    st = sim_vk_ctx_init(&s->ctx, desc ? desc->device : 0, validation, err);
    if (st == CORE_OK) {
        uint32_t maxg = s->ctx.props.limits.maxComputeWorkGroupCount[0];
        if ((s->n + SIM_VK_WG - 1) / SIM_VK_WG > maxg || (s->cells_cap + SIM_VK_WG - 1) / SIM_VK_WG > maxg)
            st = core_fail(err, CORE_EUNSUPPORTED, "vulkan: %zu particles need more workgroups than the device's %u",
                           s->n, maxg);
    }
    if (st == CORE_OK) {
        st = sim_vk_pipes_init(&s->ctx, &s->pipes, s->ns, s->nv, err);
    }
    if (st == CORE_OK) st = make_buffers(s, err);
    if (st == CORE_OK) st = make_slots(s, err);
    if (st == CORE_OK) st = sim_vk_once_init(&s->ctx, &s->once, err);
    if (st == CORE_OK) {
        /* rest positions, the contact floors after them, and COUNT zero as the sort expects on
         * entry */
        float *stage = s->staging.map;
        memcpy(stage, s->rest, s->n * 3 * sizeof(float));
        sim_groom_contact_floor(g, s->host_tmp);
        to_level_major(s, s->host_tmp, stage + 3 * s->n, 1);
        st = sim_vk_once_begin(&s->ctx, &s->once, err);
        if (st == CORE_OK) {
            VkBufferCopy c = { 0, 0, s->n * 3 * sizeof(float) };
            vkCmdCopyBuffer(s->once.cmd, s->staging.buf, s->rest_buf.buf, 1, &c);
            VkBufferCopy cf = { s->n * 3 * sizeof(float), 0, s->n * sizeof(float) };
            if (s->params.solver == SIM_SOLVER_PBD) vkCmdCopyBuffer(s->once.cmd, s->staging.buf, s->floor_buf.buf, 1, &cf);
            vkCmdFillBuffer(s->once.cmd, s->count.buf, 0, VK_WHOLE_SIZE, 0u);
            vkCmdFillBuffer(s->once.cmd, s->grid.buf, 0, VK_WHOLE_SIZE, 0u);
            st = sim_vk_once_submit_wait(&s->ctx, &s->once, err);
        }
    }
    if (st == CORE_OK && s->has_sdf) st = upload_sdf(s, g->sdf, err);
    if (st == CORE_OK) st = reset_state(s, err);
    if (st != CORE_OK) {
        vk_destroy(s);
        return st;
    }
    *out = s;
    return CORE_OK;
}

static core_status vk_create(const sim_desc *desc, const core_groom *g, const sim_params *params, void **out,
                             core_err *err)
{
    sim_vk *s = NULL;
    core_status st = create_impl(desc, NULL, g, params, &s, err);
    *out = s;
    return st;
}

static const sim_vtable vk_vtable = {
    .name = "vulkan",
    .create = vk_create,
    .set_params = vk_set_params,
    .set_motion = vk_set_motion,
    .step = vk_step,
    .read_positions = vk_read_positions,
    .write_state = vk_write_state,
    .read_state = vk_read_state,
    .reset = vk_reset,
    .get_stats = vk_get_stats,
    .destroy = vk_destroy,
};

const sim_vtable *sim_vk_vtable(void) { return &vk_vtable; }

core_status sim_vk_create(sim *out, const sim_desc *desc, const sim_vk_options *opt, const core_groom *groom,
                          const sim_params *params, core_err *err)
{
    memset(out, 0, sizeof *out);
    core_status st = sim_params_validate(params, err);
    if (st != CORE_OK) return st;
    if (params->solver != SIM_SOLVER_DFTL && params->solver != SIM_SOLVER_PBD)
        return core_fail(err, CORE_EINVAL, "vulkan: solver %s has no Vulkan backend", sim_solver_name(params->solver));
    sim_vk *s = NULL;
    st = create_impl(desc, opt, groom, params, &s, err);
    if (st != CORE_OK) return st;
    out->vt = &vk_vtable;
    out->self = s;
    out->nstrands = groom->nstrands;
    out->nverts = groom->nverts;
    out->solver = params->solver;
    out->head = core_xform_identity();
    if (desc) out->desc = *desc;
    out->desc.backend = SIM_BACKEND_VULKAN;
    return CORE_OK;
}

uint32_t sim_vk_validation_errors(const sim *s, bool *enabled)
{
    if (enabled) *enabled = false;
    if (!s || s->vt != &vk_vtable) return 0;
    const sim_vk *v = s->self;
    if (enabled) *enabled = v->ctx.validation;
    return v->ctx.validation_errors;
}
