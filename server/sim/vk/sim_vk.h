/* sim_vk: the Vulkan compute backend (same solver as the C backend, on a GPU or lavapipe). */
#ifndef SIM_VK_SIM_VK_H
#define SIM_VK_SIM_VK_H

#include <stdbool.h>
#include <stdint.h>

#include "../../core/core.h"
#include "../sim.h"

/* The Vulkan backend's function table (static storage), for the DFTL and the PBD solver
 * (params.solver, fixed for an instance). Its create uses desc->device as in sim_vk_probe. The
 * DFTL solver's serial chain along each strand runs with the paper's particle-level
 * parallelism: one dispatch per level (all strands of a level in parallel, a barrier between
 * levels); the PBD solver runs one thread per strand, one dispatch per substep, with the C
 * backend's constraint order and arithmetic. */
const sim_vtable *sim_vk_vtable(void);

/* Options beyond sim_desc; zero means default. */
typedef struct sim_vk_options {
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

/* Creates a Vulkan sim like sim_create with backend VULKAN (the solver of params->solver, which
 * must have a Vulkan backend: dftl or pbd, else CORE_EINVAL), with extra options (opt may be NULL). params must
 * be valid (sim_params_validate). *s is zeroed on failure. Sim thread. */
core_status sim_vk_create(sim *s, const sim_desc *desc, const sim_vk_options *opt, const core_groom *groom,
                          const sim_params *params, core_err *err);

/* Error messages the validation layer reported so far (0 when it is off or s is not a
 * Vulkan sim); whether it is on goes to *enabled (may be NULL). Sim thread. */
uint32_t sim_vk_validation_errors(const sim *s, bool *enabled);

#endif
