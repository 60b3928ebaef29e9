/* sim: the choice behind SIM_BACKEND_AUTO (a hardware GPU, else the faster of CPU and lavapipe). */
#ifndef SIM_SIM_SELECT_H
#define SIM_SIM_SELECT_H

#include "sim.h"

/* Creates *s for backend AUTO: the Vulkan backend when desc->device (see sim_vk_probe) is a
 * hardware GPU; on a machine whose only Vulkan device runs on the CPU (lavapipe) both backends
 * are created, a few steps of each are timed on this groom and the faster one is kept (reset
 * to the rest pose); when Vulkan cannot be set up, the C backend. Every decision and its
 * reason is logged. Fails only when the chosen fallback (the C backend) fails. Sim thread. */
core_status sim_select_auto(sim *s, const sim_desc *desc, const core_groom *groom, const sim_params *params,
                            core_err *err);

#endif
