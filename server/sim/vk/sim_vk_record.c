/* sim_vk: records a step's dispatches (SPH stages, the chain per substep, or the PBD substeps) into a
 * command buffer. */
#include "sim_vk_internal.h"

static void bind(sim_vk *s, VkCommandBuffer cmd, sim_vk_pipe_id id)
{
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s->pipes.pipe[id]);
}

static void push(sim_vk *s, VkCommandBuffer cmd, uint32_t substep, uint32_t level, uint32_t arg0, uint32_t arg1)
{
    sim_vk_push pc = { substep, level, arg0, arg1 };
    vkCmdPushConstants(cmd, s->pipes.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof pc, &pc);
}

static uint32_t groups(size_t items, uint32_t wg) { return (uint32_t)((items + wg - 1) / wg); }

static void stamp(sim_vk *s, VkCommandBuffer cmd, VkQueryPool q, uint32_t index)
{
    (void)s;
    if (q) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, q, index);
}

/* Runs one particle-parallel pipeline over all particles and waits for it. */
static void pass_n(sim_vk *s, VkCommandBuffer cmd, sim_vk_pipe_id id, uint32_t mode, uint32_t cells)
{
    bind(s, cmd, id);
    push(s, cmd, 0, 0, mode, cells);
    vkCmdDispatch(cmd, groups(s->n, SIM_VK_WG), 1, 1);
    sim_vk_barrier(cmd);
}

void sim_vk_record_sph(sim_vk *s, VkCommandBuffer cmd, VkDescriptorSet set, sim_vk_sph_mode mode, VkQueryPool queries)
{
    const uint32_t rest = mode == SIM_VK_SPH_REST ? 1u : 0u, cells = (uint32_t)s->cells_cap;
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s->pipes.layout, 0, 1, &set, 0, NULL);
    /* empty bounding box: min = all ones, max = 0 in the order-preserving encoding */
    vkCmdFillBuffer(cmd, s->grid.buf, 0, 12, 0xffffffffu);
    vkCmdFillBuffer(cmd, s->grid.buf, 12, 12, 0u);
    sim_vk_barrier(cmd);
    pass_n(s, cmd, SIM_VK_P_SPH_BOUNDS, rest, cells);
    bind(s, cmd, SIM_VK_P_SPH_GRID);
    push(s, cmd, 0, 0, rest, cells);
    vkCmdDispatch(cmd, 1, 1, 1);
    sim_vk_barrier(cmd);
    pass_n(s, cmd, SIM_VK_P_SPH_COUNT, rest, cells);
    stamp(s, cmd, queries, SIM_VK_S_GRID + 1);

    const uint32_t blocks = (uint32_t)(s->cells_cap / SIM_VK_SCAN_BLOCK);
    bind(s, cmd, SIM_VK_P_SCAN_BLOCKS);
    push(s, cmd, 0, 0, rest, cells);
    vkCmdDispatch(cmd, blocks, 1, 1);
    sim_vk_barrier(cmd);
    bind(s, cmd, SIM_VK_P_SCAN_SUMS);
    push(s, cmd, 0, 0, rest, cells);
    vkCmdDispatch(cmd, 1, 1, 1);
    sim_vk_barrier(cmd);
    bind(s, cmd, SIM_VK_P_SCAN_ADD);
    push(s, cmd, 0, 0, rest, cells);
    vkCmdDispatch(cmd, blocks, 1, 1);
    sim_vk_barrier(cmd);
    pass_n(s, cmd, SIM_VK_P_SPH_SCATTER, rest, cells);
    bind(s, cmd, SIM_VK_P_SPH_CELLSORT);
    push(s, cmd, 0, 0, rest, cells);
    vkCmdDispatch(cmd, groups(s->cells_cap, SIM_VK_WG), 1, 1);
    sim_vk_barrier(cmd);
    stamp(s, cmd, queries, SIM_VK_S_SORT + 1);

    pass_n(s, cmd, SIM_VK_P_SPH_DENSITY, rest, cells);
    stamp(s, cmd, queries, SIM_VK_S_DENSITY + 1);
    if (mode == SIM_VK_SPH_REST) return;
    pass_n(s, cmd, SIM_VK_P_SPH_FORCE, rest, cells);
    /* the positions of this evaluation, for the next one's motion (sim_step_desc.sph_inv_since) */
    const VkBufferCopy all = { 0, 0, s->n * 3 * sizeof(float) };
    vkCmdCopyBuffer(cmd, s->x.buf, s->xe.buf, 1, &all);
    sim_vk_barrier(cmd);
    stamp(s, cmd, queries, SIM_VK_S_FORCE + 1);
}

void sim_vk_record_chain(sim_vk *s, VkCommandBuffer cmd, VkDescriptorSet set)
{
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s->pipes.layout, 0, 1, &set, 0, NULL);
    bind(s, cmd, SIM_VK_P_CHAIN);
    const uint32_t K = (uint32_t)s->params.substeps, chunks = groups(s->ns, SIM_CHUNK);
    for (uint32_t k = 0; k < K; k++) {
        for (uint32_t l = 1; l < s->nv; l++) {
            push(s, cmd, k, l, 0, 0);
            vkCmdDispatch(cmd, chunks, 1, 1);
            sim_vk_barrier(cmd);
        }
    }
}

void sim_vk_record_pbd(sim_vk *s, VkCommandBuffer cmd, VkDescriptorSet set)
{
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s->pipes.layout, 0, 1, &set, 0, NULL);
    bind(s, cmd, SIM_VK_P_PBD);
    const uint32_t K = (uint32_t)s->params.substeps, g = groups(s->ns, SIM_VK_WG);
    for (uint32_t k = 0; k < K; k++) {
        push(s, cmd, k, 0, (uint32_t)s->params.pbd_iterations, 0);
        vkCmdDispatch(cmd, g, 1, 1);
        sim_vk_barrier(cmd);
    }
}
