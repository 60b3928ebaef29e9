/* sim_vk: the descriptor set layout, descriptor sets and the compute pipelines. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sim_vk_internal.h"
#include "sim_vk_spv.h"

typedef struct pipe_src {
    const char *name;
    const uint32_t *code;
    const size_t *size;
} pipe_src;

#define SRC(n) { #n, sim_vk_spv_##n, &sim_vk_spv_##n##_size }

static pipe_src source_of(sim_vk_pipe_id id)
{
    static const pipe_src chain_level = SRC(sim_chain_level);
    static const pipe_src table[SIM_VK_NPIPES] = {
        [SIM_VK_P_SPH_BOUNDS] = SRC(sim_sph_bounds),
        [SIM_VK_P_SPH_GRID] = SRC(sim_sph_grid),
        [SIM_VK_P_SPH_COUNT] = SRC(sim_sph_count),
        [SIM_VK_P_SCAN_BLOCKS] = SRC(sim_scan_blocks),
        [SIM_VK_P_SCAN_SUMS] = SRC(sim_scan_sums),
        [SIM_VK_P_SCAN_ADD] = SRC(sim_scan_add),
        [SIM_VK_P_SPH_SCATTER] = SRC(sim_sph_scatter),
        [SIM_VK_P_SPH_CELLSORT] = SRC(sim_sph_cellsort),
        [SIM_VK_P_SPH_DENSITY] = SRC(sim_sph_density),
        [SIM_VK_P_SPH_FORCE] = SRC(sim_sph_force),
        [SIM_VK_P_PBD] = SRC(sim_pbd_substep),
    };
    if (id == SIM_VK_P_CHAIN) return chain_level;
    return table[id];
}

static uint32_t wg_of(sim_vk_pipe_id id)
{
    switch (id) {
    case SIM_VK_P_CHAIN: return SIM_CHUNK;
    case SIM_VK_P_SCAN_BLOCKS:
    case SIM_VK_P_SCAN_SUMS:
    case SIM_VK_P_SCAN_ADD: return SIM_VK_SCAN_BLOCK / 2;
    case SIM_VK_P_SPH_GRID: return 1;
    default: return SIM_VK_WG;
    }
}

static core_status create_layouts(sim_vk_ctx *c, sim_vk_pipes *p, core_err *err)
{
    VkDescriptorSetLayoutBinding b[SIM_VK_NBINDINGS];
    for (uint32_t i = 0; i < SIM_VK_NBINDINGS; i++) {
        b[i] = (VkDescriptorSetLayoutBinding){
            .binding = i,
            .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
            .descriptorCount = 1,
            .stageFlags = VK_SHADER_STAGE_COMPUTE_BIT,
        };
    }
    VkDescriptorSetLayoutCreateInfo lci = {
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
        .bindingCount = SIM_VK_NBINDINGS,
        .pBindings = b,
    };
    core_status st = sim_vk_check(vkCreateDescriptorSetLayout(c->device, &lci, NULL, &p->set_layout),
                                  "vkCreateDescriptorSetLayout", err);
    if (st != CORE_OK) return st;
    VkPushConstantRange pcr = { VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(sim_vk_push) };
    VkPipelineLayoutCreateInfo pli = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
        .setLayoutCount = 1,
        .pSetLayouts = &p->set_layout,
        .pushConstantRangeCount = 1,
        .pPushConstantRanges = &pcr,
    };
    st = sim_vk_check(vkCreatePipelineLayout(c->device, &pli, NULL, &p->layout), "vkCreatePipelineLayout", err);
    if (st != CORE_OK) return st;
    VkDescriptorPoolSize ps = { VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, SIM_VK_NBINDINGS * SIM_VK_FRAMES };
    VkDescriptorPoolCreateInfo dpi = {
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
        .maxSets = SIM_VK_FRAMES,
        .poolSizeCount = 1,
        .pPoolSizes = &ps,
    };
    st = sim_vk_check(vkCreateDescriptorPool(c->device, &dpi, NULL, &p->pool), "vkCreateDescriptorPool", err);
    if (st != CORE_OK) return st;
    VkDescriptorSetLayout layouts[SIM_VK_FRAMES];
    for (int i = 0; i < SIM_VK_FRAMES; i++) layouts[i] = p->set_layout;
    VkDescriptorSetAllocateInfo ai = {
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
        .descriptorPool = p->pool,
        .descriptorSetCount = SIM_VK_FRAMES,
        .pSetLayouts = layouts,
    };
    st = sim_vk_check(vkAllocateDescriptorSets(c->device, &ai, p->sets), "vkAllocateDescriptorSets", err);
    if (st != CORE_OK) return st;
    sim_vk_name(c, VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT, (uint64_t)p->set_layout, "sim_vk set layout");
    sim_vk_name(c, VK_OBJECT_TYPE_PIPELINE_LAYOUT, (uint64_t)p->layout, "sim_vk pipeline layout");
    for (int i = 0; i < SIM_VK_FRAMES; i++)
        sim_vk_name(c, VK_OBJECT_TYPE_DESCRIPTOR_SET, (uint64_t)p->sets[i], i ? "sim_vk set frame 1" : "sim_vk set frame 0");
    return CORE_OK;
}

static core_status create_pipeline(sim_vk_ctx *c, sim_vk_pipes *p, sim_vk_pipe_id id, const sim_vk_spec *spec,
                                   core_err *err)
{
    pipe_src src = source_of(id);
    uint32_t *code = NULL;
    size_t words = 0;
    core_status st = sim_vk_spirv_exact(src.code, *src.size / 4, &code, &words, err);
    if (st != CORE_OK) return st;
    VkShaderModuleCreateInfo mci = {
        .sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
        .codeSize = words * 4,
        .pCode = code,
    };
    VkShaderModule mod = VK_NULL_HANDLE;
    char what[128];
    snprintf(what, sizeof what, "vkCreateShaderModule(%s)", src.name);
    st = sim_vk_check(vkCreateShaderModule(c->device, &mci, NULL, &mod), what, err);
    free(code);
    if (st != CORE_OK) return st;
    const VkSpecializationMapEntry entries[] = {
        { 0, offsetof(sim_vk_spec, wg), sizeof(uint32_t) },
        { 1, offsetof(sim_vk_spec, ns), sizeof(uint32_t) },
        { 2, offsetof(sim_vk_spec, nv), sizeof(uint32_t) },
    };
    VkSpecializationInfo si = { 3, entries, sizeof *spec, spec };
    VkComputePipelineCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
        .stage = {
            .sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
            .stage = VK_SHADER_STAGE_COMPUTE_BIT,
            .module = mod,
            .pName = "main",
            .pSpecializationInfo = &si,
        },
        .layout = p->layout,
    };
    snprintf(what, sizeof what, "vkCreateComputePipelines(%s)", src.name);
    st = sim_vk_check(vkCreateComputePipelines(c->device, VK_NULL_HANDLE, 1, &ci, NULL, &p->pipe[id]), what, err);
    vkDestroyShaderModule(c->device, mod, NULL);
    if (st == CORE_OK) sim_vk_name(c, VK_OBJECT_TYPE_PIPELINE, (uint64_t)p->pipe[id], src.name);
    return st;
}

core_status sim_vk_pipes_init(sim_vk_ctx *c, sim_vk_pipes *p, uint32_t ns, uint32_t nv, core_err *err)
{
    memset(p, 0, sizeof *p);
    core_status st = create_layouts(c, p, err);
    for (int id = 0; id < SIM_VK_NPIPES && st == CORE_OK; id++) {
        sim_vk_spec spec = { wg_of((sim_vk_pipe_id)id), ns, nv };
        p->wg[id] = spec.wg;
        st = create_pipeline(c, p, (sim_vk_pipe_id)id, &spec, err);
    }
    if (st != CORE_OK) sim_vk_pipes_destroy(c, p);
    return st;
}

void sim_vk_pipes_bind(sim_vk_ctx *c, sim_vk_pipes *p, int frame, sim_vk_binding b, const sim_vk_buf *buf)
{
    VkDescriptorBufferInfo bi = { buf->buf, 0, VK_WHOLE_SIZE };
    VkWriteDescriptorSet w[SIM_VK_FRAMES];
    uint32_t n = 0;
    for (int i = 0; i < SIM_VK_FRAMES; i++) {
        if (frame >= 0 && i != frame) continue;
        w[n++] = (VkWriteDescriptorSet){
            .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
            .dstSet = p->sets[i],
            .dstBinding = (uint32_t)b,
            .descriptorCount = 1,
            .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
            .pBufferInfo = &bi,
        };
    }
    vkUpdateDescriptorSets(c->device, n, w, 0, NULL);
}

void sim_vk_pipes_destroy(sim_vk_ctx *c, sim_vk_pipes *p)
{
    for (int i = 0; i < SIM_VK_NPIPES; i++)
        if (p->pipe[i]) vkDestroyPipeline(c->device, p->pipe[i], NULL);
    if (p->pool) vkDestroyDescriptorPool(c->device, p->pool, NULL);
    if (p->layout) vkDestroyPipelineLayout(c->device, p->layout, NULL);
    if (p->set_layout) vkDestroyDescriptorSetLayout(c->device, p->set_layout, NULL);
    memset(p, 0, sizeof *p);
}
