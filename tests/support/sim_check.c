/* Test support: the scripted head motion, groom fixture and geometric checks the solver tests share. */
#include "sim_check.h"

#include <setjmp.h>
#include <stdarg.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "quality.h"

#define PI 3.14159265358979323846

core_xform simcheck_head_motion(double t, double speed)
{
    double w = t * speed;
    core_xform h = core_xform_identity();
    h.pos = core_v3((float)(0.15 * sin(2.0 * PI * 1.3 * w)), (float)(0.08 * sin(2.0 * PI * 2.1 * w)),
                    (float)(0.10 * sin(2.0 * PI * 0.7 * w)));
    core_quat yaw = core_q_axis_angle(core_v3(0, 1, 0), (float)(1.2 * sin(2.0 * PI * 1.1 * w)));
    core_quat pitch = core_q_axis_angle(core_v3(1, 0, 0), (float)(0.6 * sin(2.0 * PI * 1.7 * w)));
    h.rot = core_q_norm(core_q_mul(yaw, pitch));
    return h;
}

void simcheck_groom(core_groom *g, groom_style style, uint32_t ns, uint32_t nv, uint64_t seed)
{
    core_err err;
    groom_desc gd = { .style = style, .nstrands = ns, .nverts = nv, .seed = seed };
    if (groom_procedural(&gd, g, &err) != CORE_OK) fail_msg("groom %ux%u: %s", ns, nv, err.msg);
}

bool simcheck_ratboy(core_groom *g, bool sdf)
{
    const char *assets = getenv("STRANDCAST_ASSETS");
    char path[4096];
    memset(g, 0, sizeof *g);
    snprintf(path, sizeof path, "%s/ratboy/Ratboy_mohawk.tfx", assets ? assets : "../shared/assets");
    FILE *fp = fopen(path, "rb");
    if (!fp) return false;
    fclose(fp);
    core_err err;
    if (groom_load_file(path, 0, g, &err) != CORE_OK) fail_msg("%s: %s", path, err.msg);
    if (!sdf) return true;
    snprintf(path, sizeof path, "%s/ratboy/Ratboy_body.tfxmesh", assets ? assets : "../shared/assets");
    core_mesh *m = calloc(1, sizeof *m);
    core_sdf *s = calloc(1, sizeof *s);
    assert_true(m && s);
    if (groom_mesh_load_file(path, m, &err) != CORE_OK) fail_msg("%s: %s", path, err.msg);
    groom_sdf_desc d = { .lo = core_v3(INFINITY, 0.6f, INFINITY), .hi = core_v3(-INFINITY, -INFINITY, -INFINITY) };
    for (uint32_t v = 0; v < m->nverts; v++) {
        const float *p = m->pos + 3 * v;
        if (p[1] <= 0.6f) continue;
        d.lo = core_v3(fminf(d.lo.x, p[0]), d.lo.y, fminf(d.lo.z, p[2]));
        d.hi = core_v3(fmaxf(d.hi.x, p[0]), fmaxf(d.hi.y, p[1]), fmaxf(d.hi.z, p[2]));
    }
    if (groom_sdf_build(m, &d, s, &err) != CORE_OK) fail_msg("Ratboy SDF: %s", err.msg);
    g->mesh = m;
    g->sdf = s;
    return true;
}

double simcheck_worse(double worst, double x)
{
    if (isnan(worst) || isnan(x)) return NAN;
    return x > worst ? x : worst;
}

double simcheck_dist3(const float *a, const float *b)
{
    double dx = (double)a[0] - b[0], dy = (double)a[1] - b[1], dz = (double)a[2] - b[2];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

double simcheck_mean_distance(const float *a, const float *b, size_t n)
{
    double sum = 0.0;
    for (size_t i = 0; i < n; i++) sum += simcheck_dist3(a + 3 * i, b + 3 * i);
    return sum / (double)n;
}

double simcheck_mean_strand_length(const core_groom *g)
{
    double len = 0.0;
    for (uint32_t s = 0; s < g->nstrands; s++)
        for (uint32_t l = 1; l < g->nverts; l++) {
            const float *a = g->pos + 3 * ((size_t)s * g->nverts + l);
            len += simcheck_dist3(a, a - 3);
        }
    return len / g->nstrands;
}

/* Penetration depth of p into collider c (world space under h) relative to its radius. */
static double relative_depth(const core_collider *c, core_xform h, const float *p)
{
    core_vec3 x = core_v3(p[0], p[1], p[2]);
    core_vec3 a = core_xform_point(h, c->a);
    switch (c->kind) {
    case CORE_COLLIDER_SPHERE: return (c->radius - core_v3_len(core_v3_sub(x, a))) / c->radius;
    case CORE_COLLIDER_CAPSULE: {
        core_vec3 b = core_xform_point(h, c->b), ab = core_v3_sub(b, a);
        float ab2 = core_v3_dot(ab, ab);
        /* a capsule of length 0 is a sphere */
        float t = ab2 > 0.0f ? core_v3_dot(core_v3_sub(x, a), ab) / ab2 : 0.0f;
        t = t < 0 ? 0 : t > 1 ? 1 : t;
        return (c->radius - core_v3_len(core_v3_sub(x, core_v3_add(a, core_v3_scale(ab, t))))) / c->radius;
    }
    case CORE_COLLIDER_ELLIPSOID: {
        core_vec3 u = core_q_rotate(core_q_conj(core_q_mul(h.rot, c->rot)), core_v3_sub(x, a));
        core_vec3 s = core_v3(u.x / c->radii.x, u.y / c->radii.y, u.z / c->radii.z);
        return 1.0 - core_v3_len(s); /* fraction of the radius along that direction */
    }
    }
    return 0.0;
}

double simcheck_deepest_penetration(const core_groom *g, core_xform h, const float *x)
{
    double worst = -1.0;
    for (size_t v = 0; v < (size_t)g->nstrands * g->nverts; v++) {
        if (v % g->nverts == 0) continue; /* roots are kinematic, placed by the groom */
        for (uint32_t k = 0; k < g->ncolliders; k++)
            worst = simcheck_worse(worst, relative_depth(&g->colliders[k], h, x + 3 * v));
    }
    return worst;
}

void simcheck_sphere_sdf(core_groom *g)
{
    core_err err;
    const float r = fminf(GROOM_HEAD_RX, fminf(GROOM_HEAD_RY, GROOM_HEAD_RZ)) + 0.012f, cell = 0.004f;
    const uint32_t n = (uint32_t)ceilf(2.0f * (r + 0.02f) / cell) + 1;
    const uint32_t dims[3] = { n, n, n };
    const float o = -(float)(n - 1) * cell * 0.5f;
    g->sdf = calloc(1, sizeof *g->sdf);
    assert_non_null(g->sdf);
    if (core_sdf_alloc(g->sdf, dims, core_v3(o, o, o), cell, &err) != CORE_OK) fail_msg("%s", err.msg);
    for (uint32_t k = 0; k < n; k++)
        for (uint32_t j = 0; j < n; j++)
            for (uint32_t i = 0; i < n; i++) {
                const double x = o + i * (double)cell, y = o + j * (double)cell, z = o + k * (double)cell;
                g->sdf->d[i + n * (j + (size_t)n * k)] = (float)(sqrt(x * x + y * y + z * z) - r);
            }
}

void simcheck_run_open(simcheck_run *r, const sim_params *p, int threads)
{
    core_err err;
    sim_desc d = { .backend = SIM_BACKEND_CPU, .threads = threads };
    if (sim_create(&r->s, &d, &r->groom, p, &err) != CORE_OK) fail_msg("sim_create: %s", err.msg);
    r->n = (size_t)r->groom.nstrands * r->groom.nverts;
    r->x = malloc(12 * r->n);
    r->prev = malloc(12 * r->n);
    r->scratch = malloc(4 * r->n);
    assert_true(r->x && r->prev && r->scratch);
    assert_int_equal(sim_read_positions(&r->s, r->prev, &err), CORE_OK);
}

void simcheck_run_close(simcheck_run *r)
{
    sim_destroy(&r->s);
    core_groom_free(&r->groom);
    free(r->x);
    free(r->prev);
    free(r->scratch);
}

static int cmp_float(const void *a, const void *b)
{
    const float x = *(const float *)a, y = *(const float *)b;
    return x < y ? -1 : x > y;
}

double simcheck_run_step(simcheck_run *r, core_xform h)
{
    core_err err;
    sim_set_motion(&r->s, h);
    if (sim_step(&r->s, &err) != CORE_OK) fail_msg("sim_step: %s", err.msg);
    assert_int_equal(sim_read_positions(&r->s, r->x, &err), CORE_OK);
    size_t m = 0;
    for (size_t i = 0; i < r->n; i++) {
        if (i % r->groom.nverts == 0) continue;
        const double d = simcheck_dist3(r->x + 3 * i, r->prev + 3 * i);
        r->scratch[m++] = isfinite(d) ? (float)d : INFINITY;
    }
    memcpy(r->prev, r->x, 12 * r->n);
    qsort(r->scratch, m, sizeof(float), cmp_float);
    return r->scratch[(size_t)(0.999 * (double)(m - 1))];
}

core_xform simcheck_rest_head(double t, double moving)
{
    if (t <= moving) return simcheck_head_motion(t, 1.0);
    const double w = fmin((t - moving) / 0.25, 1.0);
    core_xform from = simcheck_head_motion(moving, 1.0), h;
    h.pos = core_v3_scale(from.pos, (float)(1.0 - w));
    h.rot = core_q_norm(core_q_nlerp(from.rot, core_q_identity(), (float)w));
    return h;
}

double simcheck_motion_then_rest(simcheck_run *r, float dt, double moving, double still, double *settle)
{
    const int steps = (int)lround((moving + still) / dt);
    double last = 0.0, above = 0.0;
    for (int k = 1; k <= steps; k++) {
        const double t = k * (double)dt;
        last = simcheck_run_step(r, simcheck_rest_head(t, moving));
        if (!(last <= SIMCHECK_REST_P999 * (dt * 60.0))) above = t - moving;
    }
    if (settle) *settle = above;
    return last / (dt * 60.0);
}

double simcheck_wavy_rest(const sim_params *p, double *settle)
{
    simcheck_run r = { 0 };
    simcheck_groom(&r.groom, GROOM_WAVY, 96, 16, 11);
    simcheck_run_open(&r, p, 2);
    const double rest = simcheck_motion_then_rest(&r, p->dt, 1.0, 3.0, settle);
    simcheck_run_close(&r);
    return rest;
}

void simcheck_cantilever(core_groom *g)
{
    core_err err;
    const uint32_t ns = 64, nv = 16;
    assert_int_equal(core_groom_alloc(g, ns, nv, &err), CORE_OK);
    for (uint32_t s = 0; s < ns; s++)
        for (uint32_t v = 0; v < nv; v++) {
            float *o = g->pos + 3 * ((size_t)s * nv + v);
            o[0] = 0.1f * (float)v / (float)(nv - 1);
            o[1] = 0.002f * (float)v * (float)v / (float)((nv - 1) * (nv - 1));
            o[2] = 0.004f * (float)s;
        }
}

/* Mean height of r's tips (y of each strand's last vertex in r->x). */
static double mean_tip_height(const simcheck_run *r)
{
    double y = 0.0;
    for (uint32_t s = 0; s < r->groom.nstrands; s++) y += r->x[3 * (((size_t)s + 1) * r->groom.nverts - 1) + 1];
    return y / r->groom.nstrands;
}

void simcheck_sag_and_decay(const sim_params *p, double *sag, double *decay)
{
    simcheck_run r = { 0 };
    simcheck_cantilever(&r.groom);
    simcheck_run_open(&r, p, 2);
    const int steps = (int)lround(3.0 / p->dt);
    double *y = malloc(((size_t)steps + 1) * sizeof *y);
    assert_non_null(y);
    memcpy(r.x, r.groom.pos, 12 * r.n);
    y[0] = mean_tip_height(&r);
    double rest = 0.0;
    for (int k = 1; k <= steps; k++) {
        rest = simcheck_run_step(&r, core_xform_identity()) / (p->dt * 60.0);
        y[k] = mean_tip_height(&r);
    }
    if (!(rest <= SIMCHECK_REST_P999)) fail_msg("not at rest 3 s after the release: %.3e mm/frame", rest * 1e3);
    const double end = y[steps], level = 1e-3 * fabs(y[0] - end);
    double t_above = 0.0, e_above = fabs(y[0] - end);
    *decay = NAN;
    for (int k = 1; k < steps; k++) {
        const double e = fabs(y[k] - end);
        if (!(e >= fabs(y[k - 1] - end) && e >= fabs(y[k + 1] - end))) continue; /* not a turning point */
        if (e > level) {
            t_above = k * (double)p->dt, e_above = e;
            continue;
        }
        const double t = k * (double)p->dt;
        *decay = e > 0.0 ? t_above + (t - t_above) * log(e_above / level) / log(e_above / e) : t;
        break;
    }
    if (isnan(*decay)) fail_msg("the swing did not decay to 1/1000 of the drop within 3 s");
    *sag = r.groom.pos[3 * (r.groom.nverts - 1) + 1] - end; /* every strand starts alike */
    free(y);
    simcheck_run_close(&r);
}

void simcheck_dt_independence(const sim_params *p, double decay_tol)
{
    const struct { float dt; int k; } cases[] = { { 1.0f / 60.0f, 4 }, { 1.0f / 60.0f, 8 }, { 1.0f / 30.0f, 8 } };
    double sag[3], decay[3];
    for (int i = 0; i < 3; i++) {
        sim_params q = *p;
        q.dt = cases[i].dt;
        q.substeps = cases[i].k;
        simcheck_sag_and_decay(&q, &sag[i], &decay[i]);
        printf("%s dt %.4f s, %d substeps: tip sag %.3f mm, swing down to 1/1000 after %.3f s\n",
               sim_solver_name(p->solver), (double)q.dt, q.substeps, sag[i] * 1e3, decay[i]);
    }
    assert_true(sag[0] > 1e-3); /* the cantilever does bend */
    for (int i = 1; i < 3; i++) {
        if (!(fabs(sag[i] / sag[0] - 1.0) <= 0.10)) fail_msg("sag %d is %.3f mm, %.3f at the first", i, sag[i] * 1e3, sag[0] * 1e3);
        if (!(fabs(decay[i] - decay[0]) <= decay_tol * decay[0]))
            fail_msg("decay %d takes %.3f s, %.3f at the first", i, decay[i], decay[0]);
    }
}

void simcheck_preset_errors(const core_groom *g, const sim_params *prm, app_preset p, double secs, double min_rest,
                            double *seg, double *pen)
{
    core_err err;
    sim s;
    sim_desc d = { .backend = SIM_BACKEND_CPU, .threads = 2 };
    if (sim_create(&s, &d, g, prm, &err) != CORE_OK) fail_msg("sim_create: %s", err.msg);
    const size_t n = (size_t)g->nstrands * g->nverts;
    float *x = malloc(3 * n * sizeof(float));
    assert_non_null(x);
    *seg = 0.0, *pen = 0.0;
    const int steps = (int)lround(secs / prm->dt);
    for (int k = 1; k <= steps; k++) {
        const core_xform h = app_anim_head(p, k * (double)prm->dt, core_xform_identity());
        sim_set_motion(&s, h);
        if (sim_step(&s, &err) != CORE_OK) fail_msg("sim_step: %s", err.msg);
        assert_int_equal(sim_read_positions(&s, x, &err), CORE_OK);
        *seg = simcheck_worse(*seg, quality_segment_error_max(g, x, min_rest));
        *pen = simcheck_worse(*pen, quality_penetration_max(g, h, x));
    }
    free(x);
    sim_destroy(&s);
}
