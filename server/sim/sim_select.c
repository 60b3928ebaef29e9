/* sim: the choice behind SIM_BACKEND_AUTO (a hardware GPU, else the faster of CPU and lavapipe). */
#include <stdlib.h>
#include <string.h>

#include "sim_select.h"
#include "vk/sim_vk.h"

/* Steps timed per backend after one warm-up step. */
#define TRIAL_STEPS 3

static core_status create_kind(sim *s, const sim_desc *desc, sim_backend_kind kind, const core_groom *groom,
                               const sim_params *params, core_err *err)
{
    sim_desc d = *desc;
    d.backend = kind;
    return sim_create(s, &d, groom, params, err);
}

/* Seconds per step of s over up to TRIAL_STEPS steps (sim_time_steps), stopping early once
 * budget seconds have passed (the backend is then clearly the slower one). Negative when a
 * step fails. */
static double time_steps(sim *s, float *xyz, double budget)
{
    core_err err;
    sim_timing t;
    return sim_time_steps(s, xyz, TRIAL_STEPS, budget, &t, &err) == CORE_OK ? t.mean_s : -1.0;
}

static core_status pick_faster(sim *s, const sim_desc *desc, const core_groom *groom, const sim_params *params,
                               const char *device, core_err *err)
{
    sim vk;
    core_err why;
    if (create_kind(&vk, desc, SIM_BACKEND_VULKAN, groom, params, &why) != CORE_OK) {
        core_log(CORE_LOG_WARN, "sim", "auto: Vulkan set-up on %s failed (%s); using the CPU backend", device, why.msg);
        return create_kind(s, desc, SIM_BACKEND_CPU, groom, params, err);
    }
    core_status st = create_kind(s, desc, SIM_BACKEND_CPU, groom, params, err);
    if (st != CORE_OK) {
        sim_destroy(&vk);
        return st;
    }
    size_t n = (size_t)groom->nstrands * groom->nverts;
    float *xyz = malloc(n * 3 * sizeof(float));
    double t_cpu = xyz ? time_steps(s, xyz, 1e9) : -1.0;
    double t_vk = xyz ? time_steps(&vk, xyz, t_cpu > 0.0 ? 2.0 * TRIAL_STEPS * t_cpu : 1e9) : -1.0;
    free(xyz);
    bool use_vk = t_vk > 0.0 && (t_cpu < 0.0 || t_vk < t_cpu);
    core_log(CORE_LOG_INFO, "sim",
             "auto: no hardware GPU; %u x %u strands: CPU backend %.2f ms/step, Vulkan on %s %.2f ms/step -> %s",
             groom->nstrands, groom->nverts, t_cpu * 1e3, device, t_vk * 1e3, use_vk ? "Vulkan" : "CPU");
    if (use_vk) {
        sim_destroy(s);
        *s = vk;
    } else {
        sim_destroy(&vk);
    }
    sim_reset(s);
    return CORE_OK;
}

core_status sim_select_auto(sim *s, const sim_desc *desc, const core_groom *groom, const sim_params *params,
                            core_err *err)
{
    memset(s, 0, sizeof *s);
    sim_vk_probe_info info;
    core_err why;
    if (sim_vk_probe(desc->device, &info, &why) != CORE_OK) {
        core_log(CORE_LOG_INFO, "sim", "auto: no usable Vulkan device (%s); using the CPU backend", why.msg);
        return create_kind(s, desc, SIM_BACKEND_CPU, groom, params, err);
    }
    if (!info.hardware) return pick_faster(s, desc, groom, params, info.device_name, err);
    if (create_kind(s, desc, SIM_BACKEND_VULKAN, groom, params, &why) == CORE_OK) {
        core_log(CORE_LOG_INFO, "sim", "auto: using Vulkan on %s (hardware GPU)", info.device_name);
        return CORE_OK;
    }
    core_log(CORE_LOG_WARN, "sim", "auto: Vulkan set-up on %s failed (%s); using the CPU backend", info.device_name,
             why.msg);
    return create_kind(s, desc, SIM_BACKEND_CPU, groom, params, err);
}
