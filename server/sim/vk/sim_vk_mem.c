/* sim_vk: buffers with their memory, and blocking one-off command submissions. */
#include <stdio.h>
#include <string.h>

#include "sim_vk_internal.h"

/* The first memory type allowed by bits that has all of `want`, or UINT32_MAX. */
static uint32_t find_type(const sim_vk_ctx *c, uint32_t bits, VkMemoryPropertyFlags want)
{
    for (uint32_t i = 0; i < c->mem.memoryTypeCount; i++)
        if ((bits & (1u << i)) && (c->mem.memoryTypes[i].propertyFlags & want) == want) return i;
    return UINT32_MAX;
}

static uint32_t pick_type(const sim_vk_ctx *c, uint32_t bits, sim_vk_mem_kind kind)
{
    const VkMemoryPropertyFlags hv = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    uint32_t t = UINT32_MAX;
    switch (kind) {
    case SIM_VK_MEM_DEVICE:
        t = find_type(c, bits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
        if (t == UINT32_MAX) t = find_type(c, bits, 0);
        break;
    case SIM_VK_MEM_UPLOAD: t = find_type(c, bits, hv); break;
    case SIM_VK_MEM_READBACK:
        t = find_type(c, bits, hv | VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
        if (t == UINT32_MAX) t = find_type(c, bits, hv);
        break;
    }
    return t;
}

core_status sim_vk_buf_create(sim_vk_ctx *c, sim_vk_buf *b, VkDeviceSize size, VkBufferUsageFlags usage,
                              sim_vk_mem_kind kind, const char *name, core_err *err)
{
    memset(b, 0, sizeof *b);
    size = (size + 15u) & ~(VkDeviceSize)15u;
    if (size == 0) size = 16;
    if ((usage & VK_BUFFER_USAGE_STORAGE_BUFFER_BIT) && size > c->props.limits.maxStorageBufferRange)
        return core_fail(err, CORE_EUNSUPPORTED,
                         "vulkan: buffer %s needs %llu bytes but the device's maxStorageBufferRange is %u", name,
                         (unsigned long long)size, c->props.limits.maxStorageBufferRange);
    VkBufferCreateInfo bci = {
        .sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
        .size = size,
        .usage = usage,
        .sharingMode = VK_SHARING_MODE_EXCLUSIVE,
    };
    char what[160];
    snprintf(what, sizeof what, "vkCreateBuffer(%s)", name);
    core_status st = sim_vk_check(vkCreateBuffer(c->device, &bci, NULL, &b->buf), what, err);
    if (st != CORE_OK) return st;
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(c->device, b->buf, &req);
    uint32_t type = pick_type(c, req.memoryTypeBits, kind);
    if (type == UINT32_MAX) {
        sim_vk_buf_destroy(c, b);
        return core_fail(err, CORE_EBACKEND, "vulkan: no suitable memory type for buffer %s", name);
    }
    VkMemoryAllocateInfo mai = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
        .allocationSize = req.size,
        .memoryTypeIndex = type,
    };
    snprintf(what, sizeof what, "vkAllocateMemory(%s, %llu bytes)", name, (unsigned long long)req.size);
    st = sim_vk_check(vkAllocateMemory(c->device, &mai, NULL, &b->mem), what, err);
    if (st == CORE_OK) st = sim_vk_check(vkBindBufferMemory(c->device, b->buf, b->mem, 0), "vkBindBufferMemory", err);
    if (st == CORE_OK && kind != SIM_VK_MEM_DEVICE)
        st = sim_vk_check(vkMapMemory(c->device, b->mem, 0, VK_WHOLE_SIZE, 0, &b->map), "vkMapMemory", err);
    if (st != CORE_OK) {
        sim_vk_buf_destroy(c, b);
        return st;
    }
    b->size = size;
    c->buffer_bytes += size;
    sim_vk_name(c, VK_OBJECT_TYPE_BUFFER, (uint64_t)b->buf, name);
    sim_vk_name(c, VK_OBJECT_TYPE_DEVICE_MEMORY, (uint64_t)b->mem, name);
    return CORE_OK;
}

void sim_vk_buf_destroy(sim_vk_ctx *c, sim_vk_buf *b)
{
    if (b->map) vkUnmapMemory(c->device, b->mem);
    if (b->buf) vkDestroyBuffer(c->device, b->buf, NULL);
    if (b->mem) vkFreeMemory(c->device, b->mem, NULL);
    c->buffer_bytes -= b->size;
    memset(b, 0, sizeof *b);
}

core_status sim_vk_once_init(sim_vk_ctx *c, sim_vk_once *o, core_err *err)
{
    memset(o, 0, sizeof *o);
    VkCommandBufferAllocateInfo ai = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
        .commandPool = c->pool,
        .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
        .commandBufferCount = 1,
    };
    core_status st = sim_vk_check(vkAllocateCommandBuffers(c->device, &ai, &o->cmd), "vkAllocateCommandBuffers", err);
    if (st != CORE_OK) return st;
    VkFenceCreateInfo fci = { .sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO };
    st = sim_vk_check(vkCreateFence(c->device, &fci, NULL, &o->fence), "vkCreateFence", err);
    if (st != CORE_OK) return st;
    sim_vk_name(c, VK_OBJECT_TYPE_COMMAND_BUFFER, (uint64_t)(uintptr_t)o->cmd, "sim_vk transfer commands");
    sim_vk_name(c, VK_OBJECT_TYPE_FENCE, (uint64_t)o->fence, "sim_vk transfer fence");
    return CORE_OK;
}

void sim_vk_once_destroy(sim_vk_ctx *c, sim_vk_once *o)
{
    if (o->fence) vkDestroyFence(c->device, o->fence, NULL);
    if (o->cmd) vkFreeCommandBuffers(c->device, c->pool, 1, &o->cmd);
    memset(o, 0, sizeof *o);
}

core_status sim_vk_once_begin(sim_vk_ctx *c, sim_vk_once *o, core_err *err)
{
    (void)c;
    core_status st = sim_vk_check(vkResetCommandBuffer(o->cmd, 0), "vkResetCommandBuffer", err);
    if (st != CORE_OK) return st;
    VkCommandBufferBeginInfo bi = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
        .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
    };
    st = sim_vk_check(vkBeginCommandBuffer(o->cmd, &bi), "vkBeginCommandBuffer", err);
    if (st == CORE_OK) sim_vk_barrier(o->cmd); /* after everything submitted before */
    return st;
}

core_status sim_vk_once_submit_wait(sim_vk_ctx *c, sim_vk_once *o, core_err *err)
{
    sim_vk_barrier(o->cmd); /* make the results visible to the host */
    core_status st = sim_vk_check(vkEndCommandBuffer(o->cmd), "vkEndCommandBuffer", err);
    if (st != CORE_OK) return st;
    st = sim_vk_check(vkResetFences(c->device, 1, &o->fence), "vkResetFences", err);
    if (st != CORE_OK) return st;
    VkSubmitInfo si = {
        .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO,
        .commandBufferCount = 1,
        .pCommandBuffers = &o->cmd,
    };
    st = sim_vk_check(vkQueueSubmit(c->queue, 1, &si, o->fence), "vkQueueSubmit", err);
    if (st != CORE_OK) return st;
    return sim_vk_check(vkWaitForFences(c->device, 1, &o->fence, VK_TRUE, UINT64_MAX), "vkWaitForFences", err);
}

void sim_vk_barrier(VkCommandBuffer cmd)
{
    VkMemoryBarrier mb = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
        .srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_HOST_WRITE_BIT,
        .dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
                         VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_HOST_READ_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT,
    };
    vkCmdPipelineBarrier(cmd,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_HOST_BIT,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT |
                             VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
                         0, 1, &mb, 0, NULL, 0, NULL);
}
