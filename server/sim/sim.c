/* sim: backend selection and the thin dispatch from sim_* calls to a backend table. */
#include <string.h>

#include "sim.h"
#include "sim_cpu.h"
#include "sim_select.h"
#include "vk/sim_vk.h"

core_status sim_create(sim *s, const sim_desc *desc, const core_groom *groom, const sim_params *params,
                       core_err *err)
{
    static const sim_desc zero_desc;
    memset(s, 0, sizeof *s);
    if (!desc) desc = &zero_desc;
    core_status st = sim_params_validate(params, err);
    if (st != CORE_OK) return st;
    const sim_vtable *vt = NULL;
    switch (desc->backend) {
    case SIM_BACKEND_AUTO: return sim_select_auto(s, desc, groom, params, err);
    case SIM_BACKEND_CPU: vt = sim_cpu_vtable(); break;
    case SIM_BACKEND_VULKAN: vt = sim_vk_vtable(); break;
    }
    st = vt->create(desc, groom, params, &s->self, err);
    if (st != CORE_OK) return st;
    s->vt = vt;
    s->nstrands = groom->nstrands;
    s->nverts = groom->nverts;
    return CORE_OK;
}

core_status sim_set_params(sim *s, const sim_params *params, core_err *err)
{
    core_status st = sim_params_validate(params, err);
    if (st != CORE_OK) return st;
    return s->vt->set_params(s->self, params, err);
}

void sim_set_motion(sim *s, core_xform head) { s->vt->set_motion(s->self, head); }
core_status sim_step(sim *s, core_err *err) { return s->vt->step(s->self, err); }

bool sim_set_cancel(sim *s, sim_cancel_fn poll, void *ctx)
{
    if (!s->vt->set_cancel) return false;
    s->vt->set_cancel(s->self, poll, ctx);
    return true;
}
core_status sim_read_positions(sim *s, float *xyz, core_err *err) { return s->vt->read_positions(s->self, xyz, err); }
core_status sim_read_hairmesh(sim *s, float *xyz, core_err *err)
{
    if (!s->vt || !s->vt->read_hairmesh)
        return core_fail(err, CORE_EUNSUPPORTED, "the %s solver simulates strands, not a hair mesh",
                         s->vt ? s->vt->name : "(none)");
    return s->vt->read_hairmesh(s->self, xyz, err);
}
core_status sim_read_state(sim *s, float *xyz, float *vel, core_err *err) { return s->vt->read_state(s->self, xyz, vel, err); }
core_status sim_write_state(sim *s, const float *xyz, const float *vel, core_err *err)
{
    return s->vt->write_state(s->self, xyz, vel, err);
}
void sim_reset(sim *s) { s->vt->reset(s->self); }
void sim_get_stats(sim *s, sim_stats *out)
{
    memset(out, 0, sizeof *out);
    s->vt->get_stats(s->self, out);
}

sim_backend_kind sim_backend(const sim *s) { return s->vt == sim_vk_vtable() ? SIM_BACKEND_VULKAN : SIM_BACKEND_CPU; }

void sim_destroy(sim *s)
{
    if (s->vt) s->vt->destroy(s->self);
    memset(s, 0, sizeof *s);
}
