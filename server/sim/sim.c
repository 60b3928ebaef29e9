/* sim: solver and backend selection, the run-time solver switch and the thin dispatch from sim_*
 * calls to a backend table. */
#include <stdlib.h>
#include <string.h>

#include "sim.h"
#include "sim_cpu.h"
#include "sim_pbd.h"
#include "sim_select.h"
#include "hm/sim_hm.h"
#include "vk/sim_vk.h"

core_status sim_solver_check(const sim_params *p, const core_groom *g, core_err *err)
{
    switch (p->solver) {
    case SIM_SOLVER_DFTL:
    case SIM_SOLVER_PBD: return CORE_OK;
    case SIM_SOLVER_HAIRMESH:
        return g && g->hairmesh ? CORE_OK : core_fail(err, CORE_EINVAL, "solver hairmesh needs a hair-mesh groom");
    }
    return core_fail(err, CORE_EINVAL, "solver %d is not one of dftl, hairmesh, pbd", (int)p->solver);
}

/* The table of solver on backend kind (CPU or VULKAN), NULL when that solver has none there. */
static const sim_vtable *solver_vtable(int32_t solver, sim_backend_kind kind)
{
    switch (solver) {
    case SIM_SOLVER_DFTL: return kind == SIM_BACKEND_VULKAN ? sim_vk_vtable() : sim_cpu_vtable();
    case SIM_SOLVER_PBD: return kind == SIM_BACKEND_VULKAN ? sim_vk_vtable() : sim_pbd_vtable();
    case SIM_SOLVER_HAIRMESH: return kind == SIM_BACKEND_VULKAN ? NULL : &sim_hm_vtable;
    }
    return NULL;
}

core_status sim_create(sim *s, const sim_desc *desc, const core_groom *groom, const sim_params *params,
                       core_err *err)
{
    static const sim_desc zero_desc;
    memset(s, 0, sizeof *s);
    if (!desc) desc = &zero_desc;
    core_status st = sim_params_validate(params, err);
    if (st == CORE_OK) st = sim_solver_check(params, groom, err);
    if (st != CORE_OK) return st;
    if (desc->backend == SIM_BACKEND_AUTO && solver_vtable(params->solver, SIM_BACKEND_VULKAN))
        return sim_select_auto(s, desc, groom, params, err);
    sim_backend_kind kind = desc->backend == SIM_BACKEND_AUTO ? SIM_BACKEND_CPU : desc->backend;
    if (!solver_vtable(params->solver, kind)) {
        core_log(CORE_LOG_WARN, "sim", "solver %s has no Vulkan backend; it runs on the CPU backend",
                 sim_solver_name(params->solver));
        kind = SIM_BACKEND_CPU;
    }
    const sim_vtable *vt = solver_vtable(params->solver, kind);
    sim_desc d = *desc;
    d.backend = kind;
    st = vt->create(&d, groom, params, &s->self, err);
    if (st != CORE_OK) return st;
    s->vt = vt;
    s->nstrands = groom->nstrands;
    s->nverts = groom->nverts;
    s->desc = *desc; /* as asked: a switch to a solver that has the backend asked for gets it */
    s->solver = params->solver;
    s->head = core_xform_identity();
    return CORE_OK;
}

core_status sim_set_params(sim *s, const sim_params *params, core_err *err)
{
    core_status st = sim_params_validate(params, err);
    if (st != CORE_OK) return st;
    if (params->solver != s->solver)
        return core_fail(err, CORE_EINVAL, "parameter solver: changing it from %s to %s needs the groom (sim_change)",
                         sim_solver_name(s->solver), sim_solver_name(params->solver));
    return s->vt->set_params(s->self, params, err);
}

core_status sim_change(sim *s, const core_groom *groom, const sim_params *params, core_err *err)
{
    core_status st = sim_params_validate(params, err);
    if (st != CORE_OK || params->solver == s->solver) return st != CORE_OK ? st : s->vt->set_params(s->self, params, err);
    if ((st = sim_solver_check(params, groom, err)) != CORE_OK) return st;
    if (groom->nstrands != s->nstrands || groom->nverts != s->nverts)
        return core_fail(err, CORE_EINVAL, "solver switch: the groom (%u x %u) is not the running one (%u x %u)",
                         groom->nstrands, groom->nverts, s->nstrands, s->nverts);
    const sim_desc d = s->desc;
    const size_t n = 3 * (size_t)s->nstrands * s->nverts;
    float *xyz = malloc(n * sizeof(float)), *vel = malloc(n * sizeof(float));
    sim next;
    if (!xyz || !vel) st = core_fail(err, CORE_ENOMEM, "solver switch: out of memory for %zu floats", 2 * n);
    /* the state carries over between strand solvers; the hair-mesh solver's is its mesh, so a
     * switch to or from it starts the new solver at rest */
    const bool carry = s->solver != SIM_SOLVER_HAIRMESH && params->solver != SIM_SOLVER_HAIRMESH;
    if (st == CORE_OK && carry) st = sim_read_state(s, xyz, vel, err);
    if (st == CORE_OK && (st = sim_create(&next, &d, groom, params, err)) == CORE_OK) {
        /* under the head the old solver last had, as if it had always run there */
        sim_set_motion(&next, s->head);
        sim_reset(&next);
        if (!carry || (st = sim_write_state(&next, xyz, vel, err)) == CORE_OK) {
            core_log(CORE_LOG_INFO, "sim", "solver %s -> %s (%s backend)", sim_solver_name(s->solver),
                     sim_solver_name(params->solver), next.vt->name);
            sim_stats was;
            sim_get_stats(s, &was);
            next.prior_steps = was.steps;
            next.prior_time = was.sim_time;
            next.prior_nan_resets = was.nan_resets;
            if (s->cancel) sim_set_cancel(&next, s->cancel, s->cancel_ctx);
            sim_destroy(s);
            *s = next;
        } else {
            sim_destroy(&next);
        }
    }
    free(xyz);
    free(vel);
    return st;
}

void sim_set_motion(sim *s, core_xform head)
{
    s->head = head;
    s->vt->set_motion(s->self, head);
}
core_status sim_step(sim *s, core_err *err) { return s->vt->step(s->self, err); }

bool sim_set_cancel(sim *s, sim_cancel_fn poll, void *ctx)
{
    s->cancel = poll;
    s->cancel_ctx = ctx;
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
void sim_reset(sim *s)
{
    s->prior_steps = s->prior_nan_resets = 0;
    s->prior_time = 0.0;
    s->vt->reset(s->self);
}

void sim_get_stats(sim *s, sim_stats *out)
{
    memset(out, 0, sizeof *out);
    s->vt->get_stats(s->self, out);
    out->steps += s->prior_steps;
    out->sim_time += s->prior_time;
    out->nan_resets += s->prior_nan_resets;
}

sim_backend_kind sim_backend(const sim *s)
{
    return s->vt == sim_vk_vtable() ? SIM_BACKEND_VULKAN : SIM_BACKEND_CPU;
}

void sim_destroy(sim *s)
{
    if (s->vt) s->vt->destroy(s->self);
    memset(s, 0, sizeof *s);
}
