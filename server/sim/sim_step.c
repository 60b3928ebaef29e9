/* sim: the per-step description both backends consume (sim_step.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sim_step.h"

_Static_assert(SIM_MAX_COLLIDERS == CORE_MAX_COLLIDERS, "one collider limit");

#define MAXF(a, b) ((a) > (b) ? (a) : (b))
#define MINF(a, b) ((a) < (b) ? (a) : (b))

bool sim_step_sph_on(const sim_params *p) { return p->sph && p->repulsion + p->viscosity > 0.0f; }

/* Row-major rotation matrix of the unit quaternion q. */
static void quat_matrix(core_quat q, float m[9])
{
    const core_vec3 c[3] = { core_q_rotate(q, core_v3(1, 0, 0)), core_q_rotate(q, core_v3(0, 1, 0)),
                             core_q_rotate(q, core_v3(0, 0, 1)) };
    for (int j = 0; j < 3; j++) m[j] = (&c[j].x)[0], m[3 + j] = (&c[j].x)[1], m[6 + j] = (&c[j].x)[2];
}

void sim_world_collider(const core_collider *in, core_xform head, sim_wcollider *out)
{
    memset(out, 0, sizeof *out);
    out->kind = in->kind;
    out->a = core_xform_point(head, in->a);
    out->b = core_xform_point(head, in->b);
    out->radius = in->radius;
    float R[9];
    quat_matrix(core_q_norm(core_q_mul(head.rot, in->rot)), R);
    const float rad[3] = { in->radii.x, in->radii.y, in->radii.z };
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            out->to_unit[3 * i + j] = rad[i] > 0.0f ? R[3 * j + i] / rad[i] : 0.0f; /* row i = axis i / r_i */
            out->from_unit[3 * j + i] = R[3 * j + i] * rad[i];                    /* column i = axis i * r_i */
        }
    const bool capsule = in->kind == CORE_COLLIDER_CAPSULE;
    out->axis[0] = capsule ? out->b.x - out->a.x : 0.0f;
    out->axis[1] = capsule ? out->b.y - out->a.y : 0.0f;
    out->axis[2] = capsule ? out->b.z - out->a.z : 0.0f;
    const float ee = out->axis[0] * out->axis[0] + out->axis[1] * out->axis[1] + out->axis[2] * out->axis[2];
    out->inv_axis2 = ee > 0.0f ? 1.0f / ee : 0.0f;
    float r = in->radius;
    if (in->kind == CORE_COLLIDER_ELLIPSOID) r = MAXF(in->radii.x, MAXF(in->radii.y, in->radii.z));
    core_vec3 e = capsule ? out->b : out->a;
    out->lo[0] = MINF(out->a.x, e.x) - r, out->hi[0] = MAXF(out->a.x, e.x) + r;
    out->lo[1] = MINF(out->a.y, e.y) - r, out->hi[1] = MAXF(out->a.y, e.y) + r;
    out->lo[2] = MINF(out->a.z, e.z) - r, out->hi[2] = MAXF(out->a.z, e.z) + r;
}

/* The rigid motion from head a to head b as rows (m0 m1 m2 t): p -> Rb Ra^T (p - ta) + tb. */
static void carry_rows(core_xform a, core_xform b, float out[12])
{
    float ra[9], rb[9];
    quat_matrix(a.rot, ra);
    quat_matrix(b.rot, rb);
    const float ta[3] = { a.pos.x, a.pos.y, a.pos.z }, tb[3] = { b.pos.x, b.pos.y, b.pos.z };
    for (int i = 0; i < 3; i++) {
        float m[3], t = tb[i];
        for (int j = 0; j < 3; j++) m[j] = rb[3 * i] * ra[3 * j] + rb[3 * i + 1] * ra[3 * j + 1] + rb[3 * i + 2] * ra[3 * j + 2];
        for (int j = 0; j < 3; j++) t -= m[j] * ta[j];
        out[4 * i] = m[0], out[4 * i + 1] = m[1], out[4 * i + 2] = m[2], out[4 * i + 3] = t;
    }
}

/* The grid's box moved by head, with the transforms the samplers use. */
static void world_sdf(const core_sdf *s, core_xform head, sim_wsdf *out)
{
    float r[9];
    quat_matrix(head.rot, r);
    out->pos[0] = head.pos.x, out->pos[1] = head.pos.y, out->pos[2] = head.pos.z;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) out->from_head[3 * i + j] = r[3 * i + j], out->to_head[3 * i + j] = r[3 * j + i];
    const float lo[3] = { s->origin.x, s->origin.y, s->origin.z };
    for (int a = 0; a < 3; a++) out->lo[a] = INFINITY, out->hi[a] = -INFINITY;
    for (int c = 0; c < 8; c++) {
        core_vec3 p;
        float *pp = &p.x;
        for (int a = 0; a < 3; a++) pp[a] = (c >> a) & 1 ? lo[a] + (float)(s->dims[a] - 1) * s->cell : lo[a];
        p = core_xform_point(head, p);
        for (int a = 0; a < 3; a++) out->lo[a] = MINF(out->lo[a], pp[a]), out->hi[a] = MAXF(out->hi[a], pp[a]);
    }
    for (int a = 0; a < 3; a++) out->lo[a] -= s->cell, out->hi[a] += s->cell; /* rounding of the rotation */
}

float sim_step_shape_damping(float h)
{
    return 0.5f * (MAXF((float)SIM_SHAPE_DAMPING_STEP - h, 0.0f) + MAXF((float)SIM_FTL_DAMPING_STEP - h, 0.0f));
}

void sim_step_stiffness(const sim_params *p, uint32_t l, uint32_t nv, sim_shape_weights *out)
{
    const float h = p->dt / (float)p->substeps, h2 = h * h;
    const float t = nv > 1 ? (float)l / (float)(nv - 1) : 0.0f;
    const float fade = 1.0f + (p->stiffness_tip - 1.0f) * t;
    const float b = sim_step_shape_damping(h);
    const float kg = p->global_stiffness * fade, kl = p->local_stiffness * fade;
    const float wg = kg * h2, cg = kg * h * b, wl = kl * h2, cl = kl * h * b;
    memset(out, 0, sizeof *out);
    if (!p->shape) return;
    out->g = wg / (1.0f + wg + cg), out->gd = cg / (1.0f + wg + cg);
    out->l = wl / (1.0f + wl + cl), out->ld = cl / (1.0f + wl + cl);
}

void sim_step_plan(const sim_params *p, const sim_groom_info *g, core_xform prev_head, core_xform head,
                   sim_step_desc *out)
{
    const int K = p->substeps < 1 ? 1 : p->substeps > SIM_MAX_SUBSTEPS ? SIM_MAX_SUBSTEPS : p->substeps;
    out->dt = p->dt;
    out->substeps = K;
    out->h = p->dt / (float)K;
    out->inv_h = 1.0f / out->h;
    out->accel[0] = p->wind_x, out->accel[1] = p->wind_y - p->gravity, out->accel[2] = p->wind_z;
    out->dftl = p->dftl_correction;
    out->keep = expf(-p->damping * out->h);
    out->drag_keep = expf(-p->air_drag * out->h);
    out->ftl_damp = MAXF((float)SIM_FTL_DAMPING_STEP * out->inv_h - 1.0f, 0.0f);
    out->shape = p->shape;
    out->sph = sim_step_sph_on(p);
    out->collisions = p->collisions;
    out->sph_h = sim_sph_radius(p, g);
    /* the pressure term through the stiffness holding a vertex (sim_limits.h); times
     * rest_density, so that the pressure is k (rho - rho0) / mean rest density: a lower rest
     * density adds a bounded pressure, not one that grows as 1 / rho0 */
    const float spring = MINF(p->global_stiffness, (float)SIM_SPH_HOLD_LOCAL_SHARE * p->local_stiffness);
    const float hold = (float)SIM_SPH_ACCEL_SCALE + (p->shape ? (float)SIM_SPH_HOLD_GAIN * spring * p->stiffness_tip : 0.0f);
    out->kp = p->repulsion * p->rest_density * out->sph_h * hold;
    out->mu_dt = p->viscosity * p->dt;
    out->inv_rho0 = 1.0f / (p->rest_density * g->rho_rest);
    out->ncolliders = p->collisions ? g->ncolliders : 0;
    out->friction = p->friction;
    out->hair_friction = p->hair_friction;
    out->sdf = p->collisions ? g->sdf : NULL;
    for (int k = 0; k < K; k++) {
        out->head[k] = core_xform_lerp(prev_head, head, (float)(k + 1) / (float)K);
        for (uint32_t c = 0; c < out->ncolliders; c++) sim_world_collider(&g->colliders[c], out->head[k], &out->col[k][c]);
        carry_rows(k ? out->head[k - 1] : prev_head, out->head[k], out->carry[k]);
        if (out->sdf) world_sdf(out->sdf, out->head[k], &out->wsdf[k]);
    }
}

void sim_step_sph_clock(const sim_params *p, sim_sph_clock *clk, sim_step_desc *out)
{
    out->sph_eval = false;
    out->sph_keep = 0.0f;
    out->sph_inv_since = 0.0f;
    if (!out->sph) {
        *clk = (sim_sph_clock){ 0 };
        return;
    }
    /* whole steps per evaluation: the most that keep the rate, which grows with the repulsion
     * past SIM_SPH_RATE_REPULSION (sim_limits.h); the small margin absorbs the rounding of
     * dt = 1 / 60 in float */
    const float rate = (float)SIM_SPH_RATE * MAXF(1.0f, p->repulsion / (float)SIM_SPH_RATE_REPULSION);
    const float per = p->shape ? floorf(1.0f / (p->dt * rate) + 1e-3f) : 1.0f;
    const uint32_t every = per < 1.0f ? 1u : (uint32_t)per;
    const uint32_t elapsed = clk->age + 1u;
    out->sph_eval = !clk->warm || elapsed >= every;
    if (out->sph_eval && clk->warm && p->shape)
        out->sph_keep = expf(-(float)elapsed * p->dt / (float)SIM_SPH_SMOOTH_TIME); /* sim_limits.h */
    if (out->sph_eval && clk->warm) out->sph_inv_since = 1.0f / ((float)elapsed * p->dt);
    clk->age = out->sph_eval ? 0u : elapsed;
    clk->warm = true;
}

core_status sim_groom_check(const core_groom *g, core_err *err)
{
    if (!g || !g->pos || g->nstrands == 0 || g->nverts < 2)
        return core_fail(err, CORE_EINVAL, "groom must have at least 1 strand of 2 vertices");
    if (g->ncolliders > SIM_MAX_COLLIDERS)
        return core_fail(err, CORE_EINVAL, "groom has %u colliders, more than %d", g->ncolliders, SIM_MAX_COLLIDERS);
    size_t n, bytes;
    if (!core_mul_size(g->nstrands, g->nverts, &n) || n > UINT32_MAX / 4 || !core_mul_size(n, 3 * sizeof(float), &bytes))
        return core_fail(err, CORE_ENOMEM, "groom of %u x %u vertices is too large", g->nstrands, g->nverts);
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(g->pos[i])) return core_fail(err, CORE_EINVAL, "groom vertex %zu is not finite", i / 3);
    if (g->sdf) {
        const core_sdf *s = g->sdf;
        const uint64_t samples = (uint64_t)s->dims[0] * s->dims[1] * s->dims[2];
        if (s->dims[0] < 2 || s->dims[1] < 2 || s->dims[2] < 2 || !s->d || !(s->cell > 0.0f) || !isfinite(s->cell))
            return core_fail(err, CORE_EINVAL, "groom's distance grid is malformed (%u x %u x %u samples, cell %g)",
                             s->dims[0], s->dims[1], s->dims[2], (double)s->cell);
        if (samples > SIM_SDF_MAX_SAMPLES)
            return core_fail(err, CORE_EINVAL,
                             "groom's distance grid of %u x %u x %u samples is larger than the solver's limit of %d "
                             "samples (build it with a coarser cell or a smaller region)",
                             s->dims[0], s->dims[1], s->dims[2], SIM_SDF_MAX_SAMPLES);
        for (uint64_t i = 0; i < samples; i++)
            if (!isfinite(s->d[i])) return core_fail(err, CORE_EINVAL, "groom's distance sample %llu is not finite", (unsigned long long)i);
    }
    return CORE_OK;
}

float sim_groom_max_segment(const core_groom *g)
{
    float m = 0.0f;
    for (uint32_t s = 0; s < g->nstrands; s++)
        for (uint32_t l = 1; l < g->nverts; l++) {
            const float *a = g->pos + 3 * ((size_t)s * g->nverts + l - 1), *b = a + 3;
            const float dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
            m = fmaxf(m, sqrtf(dx * dx + dy * dy + dz * dz));
        }
    return m;
}

void sim_groom_contact_floor(const core_groom *g, float *out)
{
    const size_t n = (size_t)g->nstrands * g->nverts;
    const core_sdf *s = g->sdf;
    const float skin = (float)SIM_SDF_SKIN;
    const float lo[3] = { s ? s->origin.x : 0.0f, s ? s->origin.y : 0.0f, s ? s->origin.z : 0.0f };
    for (size_t i = 0; i < n; i++) {
        const float *q = g->pos + 3 * i;
        bool in_box = s != NULL; /* the grid's samples span lo .. lo + (dims - 1) cell */
        for (int a = 0; in_box && a < 3; a++) in_box = q[a] >= lo[a] && q[a] <= lo[a] + (float)(s->dims[a] - 1) * s->cell;
        out[i] = in_box ? fminf(skin, core_sdf_sample(s, core_v3(q[0], q[1], q[2]), NULL)) : skin;
    }
}

static int cmp_root_x(const void *a, const void *b)
{
    const float x = ((const float *)a)[0], y = ((const float *)b)[0];
    return x < y ? -1 : x > y;
}

float sim_sph_auto_radius(const core_groom *g)
{
    if (!g || g->nstrands < 2) return (float)SIM_SPH_MAX_H;
    const uint32_t n = g->nstrands;
    float *r = malloc((size_t)n * 3 * sizeof *r);
    if (!r) return (float)SIM_SPH_FALLBACK_H;
    for (uint32_t s = 0; s < n; s++) memcpy(r + 3 * (size_t)s, g->pos + 3 * (size_t)s * g->nverts, 3 * sizeof *r);
    qsort(r, n, 3 * sizeof *r, cmp_root_x); /* sweep along x: stop where |dx| alone is farther */
    double sum = 0.0;
    for (uint32_t i = 0; i < n; i++) {
        const float *a = r + 3 * (size_t)i;
        float best2 = INFINITY;
        for (int dir = -1; dir <= 1; dir += 2)
            for (int64_t j = (int64_t)i + dir; j >= 0 && j < (int64_t)n; j += dir) {
                const float *b = r + 3 * (size_t)j;
                const float dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
                if (dx * dx >= best2) break;
                const float d2 = dx * dx + dy * dy + dz * dz;
                best2 = d2 > 0.0f && d2 < best2 ? d2 : best2; /* coincident roots do not count */
            }
        sum += isfinite(best2) ? sqrt((double)best2) : 0.0;
    }
    free(r);
    const double h = SIM_SPH_AUTO_SPACINGS * sum / (double)n;
    return (float)(h < SIM_SPH_MIN_H ? SIM_SPH_MIN_H : h > SIM_SPH_MAX_H ? SIM_SPH_MAX_H : h);
}

float sim_sph_radius(const sim_params *p, const sim_groom_info *g)
{
    if (p->sph_radius > 0.0f) return p->sph_radius > (float)SIM_SPH_MIN_H ? p->sph_radius : (float)SIM_SPH_MIN_H;
    return g->sph_auto_h > 0.0f ? g->sph_auto_h : (float)SIM_SPH_FALLBACK_H;
}
