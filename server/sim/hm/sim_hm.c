/* sim_hm: the hair-mesh solver's life cycle and step (implicit Euler, collisions, deformation
 * minimization) behind the sim_vtable. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sim_hm_internal.h"

static double ms_since(unsigned long long t0) { return (double)(core_now_ns() - t0) * 1e-6; }

static void hm_destroy(void *self)
{
    sim_hm *h = self;
    if (!h) return;
    sim_hm_build_free(h);
    core_hairmesh_free(&h->mesh);
    if (h->sdf) core_sdf_free(h->sdf);
    free(h->sdf);
    float *arrays[] = { h->x, h->v, h->xs, h->xp, h->rhs, h->vn, h->dvp, h->z, h->pinv, h->r, h->c, h->q, h->s, h->w, h->xh, h->push, h->nrow, h->nrhs };
    for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; i++) free(arrays[i]);
    free(h->fixed);
    free(h->stick);
    free(h->normal);
    free(h);
}

/* Every vertex at its rest position under the current head, still. */
static void hm_reset(void *self)
{
    sim_hm *h = self;
    for (uint32_t i = 0; i < h->n; i++) {
        const float *r = h->mesh.pos + 3 * (size_t)i;
        core_vec3 p = core_xform_point(h->head, core_v3(r[0], r[1], r[2]));
        h->x[3 * i] = p.x, h->x[3 * i + 1] = p.y, h->x[3 * i + 2] = p.z;
    }
    memset(h->v, 0, 3 * (size_t)h->n * sizeof *h->v);
    memset(h->stick, 0, h->n);
    h->prev_head = h->head;
}

static core_status check_groom(const core_groom *g, core_err *err)
{
    if (!g || !g->hairmesh)
        return core_fail(err, CORE_EINVAL, "the hair-mesh solver needs a groom made from a hair mesh (groom.hairmesh is NULL)");
    core_status st = sim_groom_check(g, err);
    if (st != CORE_OK) return st;
    core_err e;
    if (core_hairmesh_validate(g->hairmesh, &e) != CORE_OK)
        return core_fail(err, CORE_EINVAL, "groom's hair mesh: %s", e.msg);
    if (g->hairmesh->nguides != g->nstrands || g->hairmesh->guide_nverts != g->nverts)
        return core_fail(err, CORE_EINVAL, "groom has %u strands of %u vertices but its hair mesh records %u guides of %u",
                         g->nstrands, g->nverts, g->hairmesh->nguides, g->hairmesh->guide_nverts);
    return CORE_OK;
}

static core_status hm_create(const sim_desc *desc, const core_groom *g, const sim_params *params, void **out,
                             core_err *err)
{
    (void)desc; /* one thread, like the paper's implementation */
    *out = NULL;
    core_status st = check_groom(g, err);
    if (st == CORE_OK) st = sim_params_validate(params, err);
    if (st != CORE_OK) return st;
    sim_hm *h = calloc(1, sizeof *h);
    if (!h) return core_fail(err, CORE_ENOMEM, "out of memory for the hair-mesh solver");
    st = core_hairmesh_copy(&h->mesh, g->hairmesh, err);
    if (st != CORE_OK) {
        free(h);
        return st;
    }
    h->ncols = h->mesh.ncols, h->nlayers = h->mesh.nlayers, h->n = h->ncols * h->nlayers;
    h->nstrands = g->nstrands, h->nverts = g->nverts;
    h->p = *params;
    h->head = h->prev_head = core_xform_identity();
    memcpy(h->colliders, g->colliders, sizeof h->colliders);
    if (g->sdf) {
        h->sdf = malloc(sizeof *h->sdf);
        st = h->sdf ? core_sdf_copy(h->sdf, g->sdf, err) : core_fail(err, CORE_ENOMEM, "out of memory copying the distance grid");
        if (st != CORE_OK) {
            free(h->sdf);
            h->sdf = NULL;
        }
    }
    h->ginfo.ncolliders = g->ncolliders;
    h->ginfo.colliders = h->colliders;
    h->ginfo.sdf = h->sdf;
    h->ginfo.rho_rest = 1.0f;
    h->ginfo.sph_auto_h = (float)SIM_SPH_FALLBACK_H;
    const size_t n3 = 3 * (size_t)h->n;
    float **arrays[] = { &h->x, &h->v, &h->xs, &h->xp, &h->rhs, &h->vn, &h->dvp, &h->z, &h->r, &h->c, &h->q, &h->s, &h->w, &h->xh, &h->push };
    for (size_t i = 0; i < sizeof arrays / sizeof arrays[0] && st == CORE_OK; i++)
        if (!(*arrays[i] = calloc(n3, sizeof(float)))) st = core_fail(err, CORE_ENOMEM, "out of memory for the hair-mesh solver");
    if (st == CORE_OK && (!(h->pinv = calloc(2 * n3, sizeof(float))) || !(h->normal = calloc(n3, sizeof(float))) ||
                          !(h->fixed = calloc(h->n, 1)) || !(h->stick = calloc(h->n, 1))))
        st = core_fail(err, CORE_ENOMEM, "out of memory for the hair-mesh solver");
    if (st == CORE_OK && !(h->nrhs = calloc(h->n, sizeof(float))))
        st = core_fail(err, CORE_ENOMEM, "out of memory for the hair-mesh solver");
    if (st == CORE_OK) st = sim_hm_build(h, err);
    if (st == CORE_OK && !(h->nrow = calloc(3 * (size_t)h->bsr.nnz, sizeof(float))))
        st = core_fail(err, CORE_ENOMEM, "out of memory for the hair-mesh solver");
    if (st != CORE_OK) {
        hm_destroy(h);
        return st;
    }
    hm_reset(h);
    *out = h;
    return CORE_OK;
}

static core_status hm_set_params(void *self, const sim_params *p, core_err *err)
{
    core_status st = sim_params_validate(p, err);
    if (st == CORE_OK) ((sim_hm *)self)->p = *p;
    return st;
}

static void hm_set_motion(void *self, core_xform head) { ((sim_hm *)self)->head = head; }

/* Friction and contact for a pushed vertex i: its velocity relative to the collider (moving with
 * the head over the substep, rows carry) loses the inward normal part, and its tangential part
 * shrinks by friction x the push (as a velocity), down to zero (Coulomb). Marked in h->stick with
 * its normal for the next implicit solve: resting (1) when friction stops it, sliding (2) when it
 * does not. */
static void contact_velocity(sim_hm *h, uint32_t i, const float carry[12], float inv_h)
{
    const float *u = h->push + 3 * (size_t)i, *p = h->xs + 3 * (size_t)i;
    const float ul = sqrtf(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (!(ul > 0.0f)) return;
    const float n[3] = { u[0] / ul, u[1] / ul, u[2] / ul };
    memcpy(h->normal + 3 * (size_t)i, n, sizeof n);
    float vc[3], vr[3];
    for (int r = 0; r < 3; r++)
        vc[r] = (carry[4 * r] * p[0] + carry[4 * r + 1] * p[1] + carry[4 * r + 2] * p[2] + carry[4 * r + 3] - p[r]) * inv_h;
    float *v = h->v + 3 * (size_t)i;
    for (int r = 0; r < 3; r++) vr[r] = v[r] - vc[r];
    float vn = vr[0] * n[0] + vr[1] * n[1] + vr[2] * n[2];
    if (vn < 0.0f) {
        for (int r = 0; r < 3; r++) vr[r] -= vn * n[r];
        vn = 0.0f;
    }
    float t[3] = { vr[0] - vn * n[0], vr[1] - vn * n[1], vr[2] - vn * n[2] };
    const float tl = sqrtf(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    const float cut = h->p.friction * ul * inv_h;
    const float keep = tl > cut ? (tl - cut) / tl : 0.0f;
    for (int r = 0; r < 3; r++) v[r] = vc[r] + vn * n[r] + t[r] * keep;
    h->stick[i] = keep == 0.0f ? SIM_HM_RESTING : SIM_HM_SLIDING;
}

/* The contacts of substep k (h->stick) turned with the head (carry's rotation): the resting ones
 * held on their colliders in its implicit solve (fixed 2, velocity the head's rigid z), the
 * sliding ones held along their normals only (sim_hm_filter_sliding). */
static void hold_contacts(sim_hm *h, const float carry[12])
{
    for (uint32_t i = 0; i < h->n; i++) {
        if (h->stick[i] == SIM_HM_FREE) continue;
        float *n = h->normal + 3 * (size_t)i;
        const float m[3] = { n[0], n[1], n[2] };
        for (int r = 0; r < 3; r++) n[r] = carry[4 * r] * m[0] + carry[4 * r + 1] * m[1] + carry[4 * r + 2] * m[2];
        if (h->stick[i] == SIM_HM_RESTING) h->fixed[i] = 2;
    }
}

/* After the implicit solve: a contact whose force along its normal (the impulse A vn - rhs of its
 * row, n^T A vn - n . rhs before the filter for a sliding one) no longer presses it onto the
 * collider is let go for the next substep. A sliding vertex's velocity along the surface relative
 * to the collider (vn - z) then loses friction x that impulse, down to zero (Coulomb), and at
 * zero it rests (held fully from the next substep). Friction decided when a held vertex came to
 * rest; letting it go when the force leaves the friction cone as well made the vertices at the
 * cone's edge chatter between held and pushed, each release shaking the mesh by up to 0.2 mm a
 * frame for ever (the curly mesh on the head). Sliding contacts used to be pushed out after every
 * solve that had moved them in instead of being held along the normal inside it: with friction 0
 * (every contact sliding) the mesh settled 3.3 s to never (more than 4 s) after the violent
 * script on the head, 2.35-2.43 s with the filter. */
static void release_contacts(sim_hm *h)
{
    for (uint32_t i = 0; i < h->n; i++) {
        if (h->stick[i] == SIM_HM_FREE) continue;
        const float *n = h->normal + 3 * (size_t)i;
        if (h->stick[i] == SIM_HM_RESTING) {
            float f[3];
            sim_hm_bsr_row_apply(&h->bsr, i, h->vn, f);
            const float *b = h->rhs + 3 * (size_t)i;
            h->stick[i] = (f[0] - b[0]) * n[0] + (f[1] - b[1]) * n[1] + (f[2] - b[2]) * n[2] > 0.0f ? SIM_HM_RESTING : SIM_HM_FREE;
            continue;
        }
        float fn = -h->nrhs[i];
        for (uint32_t k = h->bsr.row[i]; k < h->bsr.row[i + 1]; k++) {
            const float *nr = h->nrow + 3 * (size_t)k, *x = h->vn + 3 * (size_t)h->bsr.col[k];
            fn += nr[0] * x[0] + nr[1] * x[1] + nr[2] * x[2];
        }
        if (!(fn > 0.0f)) {
            h->stick[i] = SIM_HM_FREE;
            continue;
        }
        float *vn = h->vn + 3 * (size_t)i;
        const float *z = h->z + 3 * (size_t)i;
        float t[3] = { vn[0] - z[0], vn[1] - z[1], vn[2] - z[2] };
        const float tn = t[0] * n[0] + t[1] * n[1] + t[2] * n[2];
        for (int r = 0; r < 3; r++) t[r] -= tn * n[r];
        const float tl = sqrtf(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]), cut = h->p.friction * fn;
        const float lose = tl > cut ? cut / tl : 1.0f;
        for (int r = 0; r < 3; r++) vn[r] -= lose * t[r];
        if (lose == 1.0f) h->stick[i] = SIM_HM_RESTING;
    }
}

/* Collisions of the substep k: push the surface out, minimize the deformation with the pushed
 * vertices held (twice at most, each round adding the vertices the minimization moved in),
 * push once more, then update the velocities of the vertices that moved. */
static void collisions(sim_hm *h, const sim_step_desc *d, int k)
{
    const size_t n3 = 3 * (size_t)h->n;
    memset(h->push, 0, n3 * sizeof *h->push);
    memcpy(h->xp, h->x, n3 * sizeof *h->x);
    for (int round = 0; round < 3; round++) {
        unsigned long long t0 = core_now_ns();
        uint32_t moved = sim_hm_collide(h, d, k);
        h->stage_ms[2] += ms_since(t0);
        if (moved == 0 || !h->p.hm.deform_min || round == 2) break;
        t0 = core_now_ns();
        sim_hm_deform_min(h, h->xp);
        h->stage_ms[3] += ms_since(t0);
    }
    unsigned long long t0 = core_now_ns();
    for (uint32_t i = 0; i < h->n; i++) {
        if (h->fixed[i] == 1) continue;
        float *x = h->x + 3 * (size_t)i, *xp = h->xp + 3 * (size_t)i, *v = h->v + 3 * (size_t)i;
        for (int r = 0; r < 3; r++) v[r] += (x[r] - xp[r]) * d->inv_h;
        if (h->fixed[i] == 2) contact_velocity(h, i, d->carry[k], d->inv_h);
    }
    h->stage_ms[2] += ms_since(t0);
}

static void substep(sim_hm *h, const sim_step_desc *d, int k)
{
    const size_t n3 = 3 * (size_t)h->n;
    const float dt = d->h;
    const bool collide = d->ncolliders > 0 || d->sdf;
    memcpy(h->xs, h->x, n3 * sizeof *h->x);
    const float *m = d->carry[k];
    for (uint32_t i = 0; i < h->n; i++) { /* the head's rigid velocity: the free rows' cold start */
        const float *x = h->x + 3 * (size_t)i;
        for (int a = 0; a < 3; a++)
            h->z[3 * i + a] = (m[4 * a] * x[0] + m[4 * a + 1] * x[1] + m[4 * a + 2] * x[2] + m[4 * a + 3] - x[a]) * d->inv_h;
    }
    unsigned long long t0 = core_now_ns();
    sim_hm_forces(h, d->accel, dt);
    h->stage_ms[0] += ms_since(t0);
    memset(h->fixed, 0, h->n);
    if (collide) hold_contacts(h, m);
    else memset(h->stick, 0, h->n);
    for (uint32_t c = 0; c < h->ncols; c++) {
        const uint32_t i = c * h->nlayers;
        const float *r = h->mesh.pos + 3 * (size_t)i;
        const core_vec3 p = core_xform_point(d->head[k], core_v3(r[0], r[1], r[2]));
        const float tgt[3] = { p.x, p.y, p.z };
        h->fixed[i] = 1;
        for (int a = 0; a < 3; a++) h->z[3 * i + a] = (tgt[a] - h->x[3 * i + a]) * d->inv_h;
    }
    t0 = core_now_ns();
    if (collide) sim_hm_filter_sliding(h);
    sim_hm_cg(h);
    h->stage_ms[1] += ms_since(t0);
    if (collide) release_contacts(h);
    for (uint32_t i = 0; i < h->n; i++)
        for (int a = 0; a < 3; a++) {
            float *v = h->v + 3 * (size_t)i + a;
            *v = h->vn[3 * (size_t)i + a];
            h->x[3 * (size_t)i + a] += dt * *v;
        }
    for (uint32_t c = 0; c < h->ncols; c++) { /* the roots exactly on the head */
        const uint32_t i = c * h->nlayers;
        const float *r = h->mesh.pos + 3 * (size_t)i;
        const core_vec3 p = core_xform_point(d->head[k], core_v3(r[0], r[1], r[2]));
        h->x[3 * i] = p.x, h->x[3 * i + 1] = p.y, h->x[3 * i + 2] = p.z;
    }
    if (collide) collisions(h, d, k);
}

static core_status hm_step(void *self, core_err *err)
{
    sim_hm *h = self;
    const unsigned long long t0 = core_now_ns();
    sim_step_desc *d = malloc(sizeof *d);
    if (!d) return core_fail(err, CORE_ENOMEM, "out of memory for a step's description");
    sim_step_plan(&h->p, &h->ginfo, h->prev_head, h->head, d);
    memset(h->stage_ms, 0, sizeof h->stage_ms);
    for (int k = 0; k < d->substeps; k++) substep(h, d, k);
    h->prev_head = h->head;
    bool finite = true;
    for (size_t i = 0; i < 3 * (size_t)h->n && finite; i++) finite = isfinite(h->x[i]) && isfinite(h->v[i]);
    if (!finite) {
        hm_reset(h);
        h->nan_resets++;
    }
    h->steps++;
    h->sim_time += d->dt;
    free(d);
    h->last_step_ms = ms_since(t0);
    return CORE_OK;
}

static core_status hm_read_positions(void *self, float *xyz, core_err *err)
{
    (void)err;
    sim_hm *h = self;
    for (uint32_t s = 0; s < h->nstrands; s++)
        core_hairmesh_trace(&h->mesh, h->x, h->mesh.guide_face[s], h->mesh.guide_uv[2 * s], h->mesh.guide_uv[2 * s + 1],
                            h->nverts, h->mesh.guide_t + (size_t)s * h->nverts, xyz + 3 * (size_t)s * h->nverts);
    return CORE_OK;
}

static core_status hm_read_state(void *self, float *xyz, float *vel, core_err *err)
{
    (void)err;
    sim_hm *h = self;
    if (xyz) memcpy(xyz, h->x, 3 * (size_t)h->n * sizeof *xyz);
    if (vel) memcpy(vel, h->v, 3 * (size_t)h->n * sizeof *vel);
    return CORE_OK;
}

static core_status hm_write_state(void *self, const float *xyz, const float *vel, core_err *err)
{
    sim_hm *h = self;
    for (size_t i = 0; i < 3 * (size_t)h->n; i++)
        if (!isfinite(xyz[i]) || (vel && !isfinite(vel[i])))
            return core_fail(err, CORE_EINVAL, "hair mesh state value %zu is not finite", i);
    memcpy(h->x, xyz, 3 * (size_t)h->n * sizeof *xyz);
    if (vel) memcpy(h->v, vel, 3 * (size_t)h->n * sizeof *vel);
    else memset(h->v, 0, 3 * (size_t)h->n * sizeof *h->v);
    memset(h->stick, 0, h->n);
    return CORE_OK;
}

static core_status hm_read_hairmesh(void *self, float *xyz, core_err *err) { return hm_read_state(self, xyz, NULL, err); }

static void hm_get_stats(void *self, sim_stats *out)
{
    static const char *const names[4] = { "forces", "cg", "collisions", "deform_min" };
    sim_hm *h = self;
    out->steps = h->steps;
    out->sim_time = h->sim_time;
    out->nan_resets = h->nan_resets;
    out->last_step_ms = h->last_step_ms;
    out->nstages = 4;
    for (int i = 0; i < 4; i++) out->stage_ms[i] = h->stage_ms[i], out->stage_names[i] = names[i];
}

const sim_vtable sim_hm_vtable = {
    .name = "hairmesh",
    .create = hm_create,
    .set_params = hm_set_params,
    .set_motion = hm_set_motion,
    .step = hm_step,
    .read_positions = hm_read_positions,
    .write_state = hm_write_state,
    .read_state = hm_read_state,
    .reset = hm_reset,
    .get_stats = hm_get_stats,
    .destroy = hm_destroy,
    .read_hairmesh = hm_read_hairmesh,
};

core_status sim_hm_open(sim *s, const sim_desc *desc, const core_groom *groom, const sim_params *params,
                        core_err *err)
{
    memset(s, 0, sizeof *s);
    core_status st = hm_create(desc, groom, params, &s->self, err);
    if (st != CORE_OK) return st;
    s->vt = &sim_hm_vtable;
    s->nstrands = groom->nstrands;
    s->nverts = groom->nverts;
    return CORE_OK;
}
