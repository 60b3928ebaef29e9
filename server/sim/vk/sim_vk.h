/* sim_vk: the Vulkan compute backend (same solver as the C backend, on a GPU or lavapipe). */
#ifndef SIM_VK_SIM_VK_H
#define SIM_VK_SIM_VK_H

#include <stdbool.h>
#include <stdint.h>

#include "../../core/core.h"
#include "../sim.h"

/* The Vulkan backend's function table (static storage). Its create uses
 * SIM_VK_CHAIN_DEFAULT and desc->device as in sim_vk_probe. */
const sim_vtable *sim_vk_vtable(void);

/* How the serial chain along each strand is spread over the GPU.
 * LEVEL: the paper's particle-level parallelism, one dispatch per level (all strands of a
 *        level in parallel, a barrier between levels).
 * GROUP: one workgroup per chunk of 64 strands: the chunk's particles are predicted in
 *        parallel into shared memory, then one thread per strand walks its chain from there;
 *        one dispatch per substep. Needs 768 * nverts bytes of shared memory (nverts <= 42 on
 *        lavapipe, <= 63 with 48 KiB); create falls back to LEVEL otherwise. */
typedef enum sim_vk_chain {
    SIM_VK_CHAIN_DEFAULT = 0, /* the faster one as measured on lavapipe: LEVEL (BENCHMARKS.md) */
    SIM_VK_CHAIN_LEVEL,
    SIM_VK_CHAIN_GROUP
} sim_vk_chain;

/* Options beyond sim_desc; zero means default. */
typedef struct sim_vk_options {
    sim_vk_chain chain;
    bool validation; /* force the validation layer on (it is on in Debug builds anyway) */
} sim_vk_options;

/* What sim_vk_probe found. */
typedef struct sim_vk_probe_info {
    char device_name[256];
    bool hardware;     /* a discrete, integrated or virtual GPU (not a CPU device like lavapipe) */
    uint32_t index;    /* vkEnumeratePhysicalDevices index of the chosen device */
    uint32_t ndevices; /* physical devices present */
} sim_vk_probe_info;

/* Finds the device a Vulkan sim would use, without creating one. device: 0 = automatic
 * (discrete GPU, then integrated, then virtual, then CPU; the first in enumeration order
 * among equals, among devices with a compute queue and Vulkan 1.1); N >= 1 = the device at
 * vkEnumeratePhysicalDevices index N - 1 (vulkaninfo's "GPU<N-1>"). Returns CORE_EBACKEND
 * (no loader/driver, no device) or CORE_EINVAL (bad index) with the reason. Any thread. */
core_status sim_vk_probe(int device, sim_vk_probe_info *info, core_err *err);

/* Creates a Vulkan sim like sim_create with backend VULKAN, with extra options (opt may be
 * NULL). params must be valid (sim_params_validate). *s is zeroed on failure. Sim thread. */
core_status sim_vk_create(sim *s, const sim_desc *desc, const sim_vk_options *opt, const core_groom *groom,
                          const sim_params *params, core_err *err);

/* The chain strategy a Vulkan sim actually uses (after fallbacks); SIM_VK_CHAIN_DEFAULT when
 * s is not a Vulkan sim. Sim thread. */
sim_vk_chain sim_vk_chain_used(const sim *s);

/* Error messages the validation layer reported so far (0 when it is off or s is not a
 * Vulkan sim); whether it is on goes to *enabled (may be NULL). Sim thread. */
uint32_t sim_vk_validation_errors(const sim *s, bool *enabled);

#endif
