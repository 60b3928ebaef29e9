/* tests: the hair-mesh solver (sim/hm) against the 2016 paper: recovery from a collapsed mesh
 * (Figure 8) and from 10x-speed motion (Figure 7), volume kept by the deformation minimization
 * after a deep collision (Figure 9), stillness, volume and contacts at rest, the same sag at
 * any dt and substep count, the backend interface, and its linear algebra (the assembled system
 * against the matrix-free product, the two preconditioned CG solves, the sliding contacts' filter). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench/codec_synth.h"
#include "groom/groom.h"
#include "sim/hm/sim_hm.h"
#include "sim/hm/sim_hm_internal.h"
#include "sim/sim.h"
#include "support/sim_check.h"

/* The project's stillness bound: 99.9th percentile of per-frame vertex displacement, metres. */
#define REST_P999 1e-5
/* How far a surface vertex may end a step inside a collider, metres. */
#define CONTACT_DEPTH 5e-4
/* Volume kept at rest under gravity: the corner tetrahedra's total within this share of the rest one. */
#define REST_VOLUME_TOL 0.05

typedef struct hm_run {
    core_groom groom;
    sim s;
    uint32_t nv;  /* mesh vertices */
    float *x, *prev;
} hm_run;

/* A run on the procedural hair mesh d, with the default colliders when colliders > 0 and a
 * distance grid (simcheck_sphere_sdf, the collision mesh's path) as well when it is 2, plus a sphere of radius `ball` (when > 0) reaching 2 cm into the mesh
 * past the tip of the first patch's middle column (a deep collision from the first step). */
static void open_run_desc(hm_run *r, const groom_hairmesh_desc *d, int colliders, float ball, const sim_params *p)
{
    core_err err;
    core_hairmesh m;
    assert_int_equal(groom_hairmesh_procedural(d, &m, &err), CORE_OK);
    if (groom_from_hairmesh(&m, 1, 12, &r->groom, &err) != CORE_OK) fail_msg("groom_from_hairmesh: %s", err.msg);
    core_hairmesh_free(&m);
    if (colliders > 0) groom_default_colliders(&r->groom);
    if (colliders > 1) simcheck_sphere_sdf(&r->groom);
    if (ball > 0.0f) {
        const core_hairmesh *hm = r->groom.hairmesh;
        const float *q = hm->pos + 3 * ((size_t)4 * hm->nlayers + hm->nlayers - 1);
        core_vec3 tip = core_v3(q[0], q[1], q[2]), out = core_v3_norm(core_v3_sub(tip, core_v3(q[-3], q[-2], q[-1])));
        core_vec3 c = core_v3_add(tip, core_v3_scale(out, ball - 0.02f));
        core_collider *s = &r->groom.colliders[r->groom.ncolliders++];
        memset(s, 0, sizeof *s);
        s->kind = CORE_COLLIDER_SPHERE, s->a = c, s->b = c, s->radius = ball, s->rot = core_q_identity();
    }
    if (sim_hm_open(&r->s, NULL, &r->groom, p, &err) != CORE_OK) fail_msg("sim_hm_open: %s", err.msg);
    r->nv = r->groom.hairmesh->ncols * r->groom.hairmesh->nlayers;
    r->x = malloc(12 * (size_t)r->nv);
    r->prev = malloc(12 * (size_t)r->nv);
    assert_true(r->x && r->prev);
}

/* open_run_desc on the straight mesh of patches x patches patches and `layers` layers. */
static void open_run_ball(hm_run *r, uint32_t patches, uint32_t layers, bool colliders, float ball, const sim_params *p)
{
    const groom_hairmesh_desc d = { .patches = patches, .nlayers = layers };
    open_run_desc(r, &d, colliders, ball, p);
}

static void open_run(hm_run *r, uint32_t patches, uint32_t layers, bool colliders, const sim_params *p)
{
    open_run_ball(r, patches, layers, colliders, 0.0f, p);
}

static void close_run(hm_run *r)
{
    sim_destroy(&r->s);
    core_groom_free(&r->groom);
    free(r->x);
    free(r->prev);
}

static void steps(hm_run *r, int n)
{
    core_err err;
    for (int i = 0; i < n; i++) assert_int_equal(sim_step(&r->s, &err), CORE_OK);
}

static void mesh_now(hm_run *r, float *out)
{
    core_err err;
    assert_int_equal(sim_read_hairmesh(&r->s, out, &err), CORE_OK);
}

static double tet(const float *x, const uint32_t id[4])
{
    const float *p0 = x + 3 * id[0];
    double e[3][3];
    for (int j = 0; j < 3; j++)
        for (int a = 0; a < 3; a++) e[j][a] = (double)x[3 * id[j + 1] + a] - p0[a];
    return (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
            e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0])) / 6.0;
}

/* The total signed volume of every prism's corner tetrahedra (the solver's volume elements); with
 * rest, the volume they lost instead: the sum over the tetrahedra of max(0, rest volume - volume),
 * so that an inverted tetrahedron cannot be made up for by a stretched one. */
static double tet_volume(const core_hairmesh *m, const float *x, const float *rest)
{
    double sum = 0.0;
    for (uint32_t f = 0; f < m->nfaces; f++) {
        const uint32_t *c = m->faces + 4 * (size_t)f;
        uint32_t nc = c[3] == CORE_HAIRMESH_NONE ? 3 : 4;
        for (uint32_t l = 0; l + 1 < m->nlayers; l++)
            for (uint32_t k = 0; k < nc; k++) {
                uint32_t cn = c[(k + 1) % nc], cp = c[(k + nc - 1) % nc];
                for (int top = 0; top < 2; top++) {
                    uint32_t la = l + (uint32_t)top, lb = l + 1 - (uint32_t)top;
                    uint32_t id[4] = { c[k] * m->nlayers + la, (top ? cp : cn) * m->nlayers + la,
                                       (top ? cn : cp) * m->nlayers + la, c[k] * m->nlayers + lb };
                    double v = tet(x, id);
                    sum += rest ? fmax(0.0, tet(rest, id) - v) : v;
                }
            }
    }
    return sum;
}

static double mesh_volume(const core_hairmesh *m, const float *x) { return tet_volume(m, x, NULL); }

static double dist(const float *a, const float *b)
{
    double dx = (double)a[0] - b[0], dy = (double)a[1] - b[1], dz = (double)a[2] - b[2];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

static double mean_dist(const float *a, const float *b, uint32_t n)
{
    double s = 0.0;
    for (uint32_t i = 0; i < n; i++) s += dist(a + 3 * i, b + 3 * i);
    return s / n;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* The deepest a vertex (of those mask marks, all when NULL) sits inside g's colliders (0 if none). */
static double deepest(const core_groom *g, const float *x, uint32_t n, const uint8_t *mask)
{
    double worst = 0.0;
    for (uint32_t i = 0; i < n; i++) {
        if (mask && !mask[i]) continue;
        const float *p = x + 3 * i;
        for (uint32_t k = 0; k < g->ncolliders; k++) {
            const core_collider *c = &g->colliders[k];
            double depth = 0.0;
            if (c->kind == CORE_COLLIDER_ELLIPSOID) {
                double u = (p[0] - c->a.x) / c->radii.x, v = (p[1] - c->a.y) / c->radii.y, w = (p[2] - c->a.z) / c->radii.z;
                double s = sqrt(u * u + v * v + w * w);
                double rmin = fmin(c->radii.x, fmin(c->radii.y, c->radii.z));
                depth = s < 1.0 ? (1.0 - s) * rmin : 0.0;
            } else {
                double ax = c->b.x - c->a.x, ay = c->b.y - c->a.y, az = c->b.z - c->a.z;
                double ee = ax * ax + ay * ay + az * az;
                double t = ee > 0 ? ((p[0] - c->a.x) * ax + (p[1] - c->a.y) * ay + (p[2] - c->a.z) * az) / ee : 0.0;
                t = t < 0 ? 0 : t > 1 ? 1 : t;
                double dx = p[0] - (c->a.x + ax * t), dy = p[1] - (c->a.y + ay * t), dz = p[2] - (c->a.z + az * t);
                double d = sqrt(dx * dx + dy * dy + dz * dz);
                depth = d < c->radius ? c->radius - d : 0.0;
            }
            worst = fmax(worst, depth);
        }
    }
    return worst;
}

/* 1 for each vertex on the mesh's outer surface (the tip layer, and every layer past the root of
 * a column on an edge used by one face), 0 elsewhere; the caller frees it. */
static uint8_t *surface_of(const core_hairmesh *m)
{
    uint8_t *s = calloc((size_t)m->ncols * m->nlayers, 1);
    assert_non_null(s);
    for (uint32_t f = 0; f < m->nfaces; f++)
        for (uint32_t k = 0; k < 4; k++) {
            uint32_t a = m->faces[4 * f + k], b = m->faces[4 * f + (k + 1) % 4], uses = 0;
            for (uint32_t g = 0; g < m->nfaces; g++)
                for (uint32_t j = 0; j < 4; j++) {
                    uint32_t c = m->faces[4 * g + j], d = m->faces[4 * g + (j + 1) % 4];
                    uses += (c == a && d == b) || (c == b && d == a);
                }
            if (uses == 1)
                for (uint32_t l = 1; l < m->nlayers; l++) s[a * m->nlayers + l] = s[b * m->nlayers + l] = 1;
        }
    for (uint32_t c = 0; c < m->ncols; c++) s[c * m->nlayers + m->nlayers - 1] = 1;
    return s;
}

/* Settles the mesh under gravity with no collider, the reference rest shape. */
static void settled_reference(uint32_t patches, uint32_t layers, bool colliders, const sim_params *p, float *out)
{
    hm_run r;
    open_run(&r, patches, layers, colliders, p);
    steps(&r, (int)(4.0f / p->dt));
    mesh_now(&r, out);
    close_run(&r);
}

static void test_interface(void **state)
{
    (void)state;
    core_err err;
    sim_params p;
    sim_params_default(&p);
    core_groom plain;
    groom_desc gd = { .nstrands = 16, .nverts = 8 };
    assert_int_equal(groom_procedural(&gd, &plain, &err), CORE_OK);
    sim s;
    assert_int_equal(sim_hm_open(&s, NULL, &plain, &p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "hair mesh"));
    sim_desc cd = { .backend = SIM_BACKEND_CPU, .threads = 1 };
    assert_int_equal(sim_create(&s, &cd, &plain, &p, &err), CORE_OK);
    float xyz[3 * 64];
    assert_int_equal(sim_read_hairmesh(&s, xyz, &err), CORE_EUNSUPPORTED);
    sim_destroy(&s);
    core_groom_free(&plain);

    hm_run r;
    open_run(&r, 2, 4, true, &p);
    /* a hair mesh that does not record the groom's strands, or a broken one, is refused */
    core_groom bad;
    assert_int_equal(core_groom_copy(&bad, &r.groom, &err), CORE_OK);
    bad.hairmesh->nguides = 3;
    assert_int_equal(sim_hm_open(&s, NULL, &bad, &p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "guides"));
    bad.hairmesh->nguides = bad.nstrands;
    bad.hairmesh->faces[0] = 1u << 30;
    assert_int_equal(sim_hm_open(&s, NULL, &bad, &p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "out of range"));
    core_groom_free(&bad);
    /* at rest the strands are the groom's traced guides */
    size_t n = (size_t)r.groom.nstrands * r.groom.nverts;
    float *pos = malloc(12 * n);
    assert_int_equal(sim_read_positions(&r.s, pos, &err), CORE_OK);
    for (size_t i = 0; i < 3 * n; i++) assert_float_equal(pos[i], r.groom.pos[i], 1e-6);
    free(pos);
    /* parameters: the hm_ entries of sim_params' table apply to the hair-mesh solver only; bad
     * values are refused like any parameter's */
    size_t count, nhm = 0;
    const core_param_info *t = sim_param_table(&count);
    for (size_t i = 0; i < count; i++) {
        if (strncmp(t[i].name, "hm_", 3) != 0) continue;
        nhm++;
        assert_non_null(t[i].solvers);
        assert_string_equal(t[i].solvers[0], "hairmesh");
        assert_null(t[i].solvers[1]);
    }
    assert_int_equal(nhm, 8);
    sim_params bad_p = p;
    bad_p.hm.cg_tolerance = NAN;
    assert_int_equal(sim_set_params(&r.s, &bad_p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "hm_cg_tolerance"));
    bad_p = p;
    bad_p.hm.volume_stiffness = -10.0f;
    assert_int_equal(sim_set_params(&r.s, &bad_p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "hm_volume_stiffness"));
    bad_p = p;
    bad_p.hm.cg_iterations = 0;
    assert_int_equal(sim_set_params(&r.s, &bad_p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "hm_cg_iterations"));
    /* state round trip, non-finite refused, reset */
    steps(&r, 5);
    float *v = malloc(12 * (size_t)r.nv);
    assert_int_equal(sim_read_state(&r.s, r.x, v, &err), CORE_OK);
    r.x[7] += 0.01f;
    assert_int_equal(sim_write_state(&r.s, r.x, v, &err), CORE_OK);
    mesh_now(&r, r.prev);
    assert_memory_equal(r.prev, r.x, 12 * (size_t)r.nv);
    r.x[0] = NAN;
    assert_int_equal(sim_write_state(&r.s, r.x, NULL, &err), CORE_EINVAL);
    sim_reset(&r.s);
    mesh_now(&r, r.x);
    assert_memory_equal(r.x, r.groom.hairmesh->pos, 12 * (size_t)r.nv);
    /* stages */
    steps(&r, 1);
    sim_stats st;
    sim_get_stats(&r.s, &st);
    assert_int_equal(st.steps, 6);
    assert_int_equal(st.nstages, 4);
    assert_string_equal(st.stage_names[1], "cg");
    assert_string_equal(st.stage_names[3], "deform_min");
    assert_true(st.stage_ms[0] > 0.0 && st.stage_ms[1] > 0.0);
    free(v);
    close_run(&r);
}

/* At rest under gravity on the default character: still, volume kept, no vertex in a collider. */
static void test_rest(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    hm_run r;
    open_run(&r, 2, 7, true, &p);
    uint8_t *surf = surface_of(r.groom.hairmesh);
    const double v0 = mesh_volume(r.groom.hairmesh, r.groom.hairmesh->pos);
    double worst = 0.0;
    for (int i = 0; i < 300; i++) {
        steps(&r, 1);
        mesh_now(&r, r.x);
        worst = fmax(worst, deepest(&r.groom, r.x, r.nv, surf));
    }
    const int frames = 60;
    double *d = malloc(sizeof *d * (size_t)frames * r.nv);
    mesh_now(&r, r.prev);
    for (int f = 0; f < frames; f++) {
        steps(&r, 1);
        mesh_now(&r, r.x);
        worst = fmax(worst, deepest(&r.groom, r.x, r.nv, surf));
        for (uint32_t i = 0; i < r.nv; i++) d[(size_t)f * r.nv + i] = dist(r.x + 3 * i, r.prev + 3 * i);
        memcpy(r.prev, r.x, 12 * (size_t)r.nv);
    }
    qsort(d, (size_t)frames * r.nv, sizeof *d, cmp_double);
    const double p999 = d[(size_t)(0.999 * (frames * r.nv - 1))];
    const double vol = mesh_volume(r.groom.hairmesh, r.x);
    print_message("rest: p99.9 %.3g mm/frame, volume %.4f of rest, deepest contact %.3g mm\n", p999 * 1e3, vol / v0,
                  worst * 1e3);
    assert_true(p999 <= REST_P999);
    assert_true(fabs(vol / v0 - 1.0) <= REST_VOLUME_TOL);
    assert_true(worst <= CONTACT_DEPTH);
    sim_stats st;
    sim_get_stats(&r.s, &st);
    assert_int_equal(st.nan_resets, 0);
    free(d);
    free(surf);
    close_run(&r);
}

/* Settled sag (mean distance of the tip layer from its rest place) at three dt / substep pairs. */
static void test_sag_same_at_any_step(void **state)
{
    (void)state;
    const float dts[3] = { 1.0f / 60.0f, 1.0f / 60.0f, 1.0f / 30.0f };
    const int subs[3] = { 4, 8, 8 };
    double sag[3];
    for (int c = 0; c < 3; c++) {
        sim_params p;
        sim_params_default(&p);
        p.dt = dts[c], p.substeps = subs[c];
        hm_run r;
        open_run(&r, 2, 6, false, &p);
        steps(&r, (int)(4.0f / p.dt));
        mesh_now(&r, r.x);
        const core_hairmesh *m = r.groom.hairmesh;
        double s = 0.0;
        for (uint32_t col = 0; col < m->ncols; col++) {
            size_t i = (size_t)col * m->nlayers + m->nlayers - 1;
            s += dist(r.x + 3 * i, m->pos + 3 * i);
        }
        sag[c] = s / m->ncols;
        close_run(&r);
    }
    print_message("sag: %.3f mm (1/60 x 4), %.3f mm (1/60 x 8), %.3f mm (1/30 x 8)\n", sag[0] * 1e3, sag[1] * 1e3,
                  sag[2] * 1e3);
    assert_true(sag[0] > 1e-4);
    for (int c = 1; c < 3; c++) assert_true(fabs(sag[c] / sag[0] - 1.0) <= 0.10);
}

/* The settled sag of the tip layer (mean distance from its rest place) under sim_params p, the
 * solver opened at the defaults and p applied with sim_set_params (the path a set_params takes). */
static double settled_sag(const sim_params *p)
{
    sim_params d;
    sim_params_default(&d);
    hm_run r;
    open_run(&r, 2, 6, false, &d);
    core_err err;
    assert_int_equal(sim_set_params(&r.s, p, &err), CORE_OK);
    steps(&r, (int)(3.0f / p->dt));
    mesh_now(&r, r.x);
    const core_hairmesh *m = r.groom.hairmesh;
    double s = 0.0;
    for (uint32_t col = 0; col < m->ncols; col++) {
        size_t i = (size_t)col * m->nlayers + m->nlayers - 1;
        s += dist(r.x + 3 * i, m->pos + 3 * i);
    }
    s /= m->ncols;
    close_run(&r);
    return s;
}

/* hm_bend_stiffness set at run time reaches the solver: a stiffer bend sags less, a weaker one more. */
static void test_bend_param_changes_sag(void **state)
{
    (void)state;
    const float bends[3] = { 2.0e3f, 2.0e4f, 2.0e5f };
    double sag[3];
    for (int c = 0; c < 3; c++) {
        sim_params p;
        sim_params_default(&p);
        p.hm.bend_stiffness = bends[c];
        sag[c] = settled_sag(&p);
    }
    print_message("sag: %.3f mm (bend 2e3), %.3f mm (2e4), %.3f mm (2e5)\n", sag[0] * 1e3, sag[1] * 1e3, sag[2] * 1e3);
    assert_true(sag[0] > 1.05 * sag[1]);
    assert_true(sag[1] > 1.05 * sag[2]);
}

/* Every hm_ parameter at its minimum and maximum (the others at default), set at run time under
 * a nodding head: the solver takes it and stays finite (no NaN reset) for 1 s. */
static void test_hm_params_at_extremes(void **state)
{
    (void)state;
    size_t count;
    const core_param_info *t = sim_param_table(&count);
    int tried = 0;
    for (size_t i = 0; i < count; i++) {
        if (strncmp(t[i].name, "hm_", 3) != 0) continue;
        for (int end = 0; end < 2; end++) {
            sim_params p;
            sim_params_default(&p);
            hm_run r;
            open_run(&r, 2, 5, true, &p);
            char *f = (char *)&p + t[i].offset;
            const double v = end ? t[i].max : t[i].min;
            if (t[i].type == CORE_PARAM_FLOAT) *(float *)f = (float)v;
            else if (t[i].type == CORE_PARAM_INT) *(int32_t *)f = (int32_t)v;
            else *(bool *)f = v != 0.0;
            core_err err;
            if (sim_set_params(&r.s, &p, &err) != CORE_OK) fail_msg("%s = %g: %s", t[i].name, v, err.msg);
            for (int k = 0; k < 60; k++) {
                const float a = 0.4f * sinf(6.0f * (float)k / 60.0f);
                sim_set_motion(&r.s, (core_xform){ core_v3(0.0f, 0.0f, 0.0f), core_q_axis_angle(core_v3(1.0f, 0.0f, 0.0f), a) });
                steps(&r, 1);
            }
            mesh_now(&r, r.x);
            for (uint32_t k = 0; k < 3 * r.nv; k++)
                if (!isfinite(r.x[k])) fail_msg("%s = %g: vertex value %u is not finite", t[i].name, v, k);
            sim_stats st;
            sim_get_stats(&r.s, &st);
            if (st.nan_resets != 0) fail_msg("%s = %g: %llu NaN resets", t[i].name, v, (unsigned long long)st.nan_resets);
            close_run(&r);
            tried++;
        }
    }
    assert_int_equal(tried, 16);
}

/* Figure 8: every vertex placed on its root recovers the rest shape (no colliders). */
static void test_collapse_recovers(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    hm_run r;
    open_run(&r, 2, 6, false, &p);
    float *ref = malloc(12 * (size_t)r.nv);
    settled_reference(2, 6, false, &p, ref);
    const core_hairmesh *m = r.groom.hairmesh;
    for (uint32_t c = 0; c < m->ncols; c++)
        for (uint32_t l = 0; l < m->nlayers; l++)
            memcpy(r.x + 3 * ((size_t)c * m->nlayers + l), m->pos + 3 * (size_t)c * m->nlayers, 12);
    core_err err;
    assert_int_equal(sim_write_state(&r.s, r.x, NULL, &err), CORE_OK);
    assert_true(mesh_volume(m, r.x) == 0.0);
    steps(&r, 240);
    mesh_now(&r, r.x);
    const double md = mean_dist(r.x, ref, r.nv);
    print_message("collapse: mean distance from the rest shape %.3f mm after 4 s\n", md * 1e3);
    assert_true(md < 1e-3);
    free(ref);
    close_run(&r);
}

/* Figure 7: head motion at 10x speed (a 1.5 Hz, 0.6 rad shake and 1 Hz, 5 cm sway played at 15 and
 * 10 Hz for a second), then still: the mesh
 * returns to its settled shape. */
static void test_fast_motion_recovers(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    hm_run r;
    open_run(&r, 2, 6, true, &p);
    float *ref = malloc(12 * (size_t)r.nv);
    settled_reference(2, 6, true, &p, ref);
    uint8_t *surf = surface_of(r.groom.hairmesh);
    double worst = 0.0;
    for (int i = 0; i < 60; i++) {
        float a = 0.6f * sinf(2.0f * 3.14159265f * 15.0f * (float)(i + 1) * p.dt);
        core_xform head = core_xform_identity();
        head.rot = core_q_axis_angle(core_v3(0.0f, 1.0f, 0.0f), a);
        head.pos.x = 0.05f * sinf(2.0f * 3.14159265f * 10.0f * (float)(i + 1) * p.dt);
        sim_set_motion(&r.s, head);
        steps(&r, 1);
        mesh_now(&r, r.x);
        for (uint32_t v = 0; v < r.nv; v++) { /* the colliders in the head frame */
            core_vec3 q = core_q_rotate(core_q_conj(head.rot), core_v3_sub(core_v3(r.x[3 * v], r.x[3 * v + 1], r.x[3 * v + 2]), head.pos));
            r.prev[3 * v] = q.x, r.prev[3 * v + 1] = q.y, r.prev[3 * v + 2] = q.z;
        }
        worst = fmax(worst, deepest(&r.groom, r.prev, r.nv, surf));
    }
    sim_set_motion(&r.s, core_xform_identity());
    steps(&r, 360);
    mesh_now(&r, r.x);
    const double md = mean_dist(r.x, ref, r.nv);
    sim_stats st;
    sim_get_stats(&r.s, &st);
    print_message("fast motion: mean distance from the settled shape %.3f mm 6 s after; deepest surface contact %.3f mm\n",
                  md * 1e3, worst * 1e3);
    assert_int_equal(st.nan_resets, 0);
    assert_true(worst <= CONTACT_DEPTH);
    free(surf);
    assert_true(md < 1e-3);
    free(ref);
    close_run(&r);
}

/* Figure 9: a ball of 5 cm radius reaching 2 cm into the mesh from the first step (1/30 s steps,
 * no substeps): the volume the corner tetrahedra lost (tetrahedron by tetrahedron) 8 steps later
 * is smaller with the deformation minimization than without. The procedural mesh is a thin sheet
 * lying on the head: a 3 cm ball pushes few of its prisms (2.3% lost either way, within the
 * solver's tolerance); from a 4.5 cm ball on the difference is clear (5 cm: 3.3% against 2.2%). */
static void test_deform_min_keeps_volume(void **state)
{
    (void)state;
    double loss[2];
    for (int on = 0; on < 2; on++) {
        sim_params p;
        sim_params_default(&p);
        p.dt = 1.0f / 30.0f, p.substeps = 1; /* large time steps, where the paper sees the difference */
        hm_run r;
        open_run_ball(&r, 2, 6, false, 0.05f, &p);
        core_err err;
        p.hm.deform_min = on != 0;
        assert_int_equal(sim_set_params(&r.s, &p, &err), CORE_OK);
        const core_hairmesh *m = r.groom.hairmesh;
        const double v0 = mesh_volume(m, m->pos);
        steps(&r, 8);
        mesh_now(&r, r.x);
        loss[on] = tet_volume(m, r.x, m->pos) / v0;
        close_run(&r);
    }
    print_message("deep collision: volume lost %.3f%% without, %.3f%% with deformation minimization\n",
                  loss[0] * 100.0, loss[1] * 100.0);
    assert_true(loss[1] < loss[0]);
}

/* The character's collision mesh (a box under the hair, as its distance grid): the mesh comes to
 * rest on it, no surface vertex ends a step more than CONTACT_DEPTH inside it. */
static void test_sdf_contact(void **state)
{
    (void)state;
    core_err err;
    core_hairmesh m;
    groom_hairmesh_desc d = { .patches = 2, .nlayers = 6 };
    assert_int_equal(groom_hairmesh_procedural(&d, &m, &err), CORE_OK);
    float tip = 1.0f;
    for (uint32_t c = 0; c < m.ncols; c++) tip = fminf(tip, m.pos[3 * ((size_t)c * m.nlayers + m.nlayers - 1) + 1]);
    hm_run r;
    assert_int_equal(groom_from_hairmesh(&m, 1, 8, &r.groom, &err), CORE_OK);
    core_hairmesh_free(&m);
    static const uint32_t quads[6][4] = { { 0, 2, 3, 1 }, { 4, 5, 7, 6 }, { 0, 1, 5, 4 }, { 2, 6, 7, 3 }, { 0, 4, 6, 2 }, { 1, 3, 7, 5 } };
    core_mesh box;
    assert_int_equal(core_mesh_alloc(&box, 8, 12, &err), CORE_OK);
    const float top = tip + 0.03f; /* 3 cm above the lowest tip */
    for (uint32_t i = 0; i < 8; i++) {
        box.pos[3 * i] = i & 1 ? 0.4f : -0.4f;
        box.pos[3 * i + 1] = i & 2 ? top : top - 0.1f;
        box.pos[3 * i + 2] = i & 4 ? 0.4f : -0.4f;
    }
    for (uint32_t q = 0; q < 6; q++) {
        const uint32_t *v = quads[q];
        uint32_t t[6] = { v[0], v[1], v[2], v[0], v[2], v[3] };
        memcpy(box.tri + 6 * q, t, sizeof t);
    }
    r.groom.sdf = malloc(sizeof *r.groom.sdf);
    groom_sdf_desc sd = { .cell = 0.008f };
    assert_int_equal(groom_sdf_build(&box, &sd, r.groom.sdf, &err), CORE_OK);
    sim_params p;
    sim_params_default(&p);
    assert_int_equal(sim_hm_open(&r.s, NULL, &r.groom, &p, &err), CORE_OK);
    r.nv = r.groom.hairmesh->ncols * r.groom.hairmesh->nlayers;
    r.x = malloc(12 * (size_t)r.nv);
    r.prev = malloc(12 * (size_t)r.nv);
    uint8_t *surf = surface_of(r.groom.hairmesh);
    double worst = 0.0, lowest = 1.0;
    for (int i = 0; i < 120; i++) {
        steps(&r, 1);
        mesh_now(&r, r.x);
        for (uint32_t v = 0; v < r.nv; v++) {
            const float *q = r.x + 3 * v;
            lowest = fmin(lowest, q[1]);
            if (!surf[v]) continue;
            worst = fmax(worst, (double)(top - q[1]));
        }
    }
    print_message("collision mesh: deepest surface vertex %.3f mm below the box top (lowest vertex %.1f mm above it)\n",
                  worst * 1e3, (lowest - top) * 1e3);
    assert_true(worst <= CONTACT_DEPTH);
    core_mesh_free(&box);
    free(surf);
    close_run(&r);
}

/* A value in [-1, 1) from the state *x (a 32-bit LCG). */
static float lcg(uint32_t *x)
{
    *x = *x * 1664525u + 1013904223u;
    return (float)(*x >> 8) / 8388608.0f - 1.0f;
}

/* A run on the smaller paper mesh at the default parameters after 20 frames of a turning head:
 * triangles stretched, sheared and bent, tetrahedra deformed. With tight, its solves then stop at a
 * 1e-6 tolerance (up to 1000 iterations). */
static sim_hm *moved_run(hm_run *r, bool tight)
{
    sim_params p;
    sim_params_default(&p);
    open_run(r, 2, 6, true, &p);
    for (int f = 0; f < 20; f++) {
        core_xform head = core_xform_identity();
        head.rot = core_q_axis_angle(core_v3(0.0f, 1.0f, 0.0f), 0.05f * (float)f);
        sim_set_motion(&r->s, head);
        steps(r, 1);
    }
    sim_hm *h = r->s.self;
    if (tight) h->p.hm.cg_tolerance = 1e-6f, h->p.hm.cg_iterations = 1000;
    return h;
}

/* y = A x for the implicit step's system from its condition rows' terms w g (g . x), the pair
 * dampers' and the stretched triangles' second derivative, matrix-free: the reference the
 * assembled block-sparse system (sim_hm_bsr) is pinned against. */
static void matrix_free_apply(const sim_hm *h, const float *x, float *y)
{
    const float d = h->diag;
    for (size_t i = 0; i < 3 * (size_t)h->n; i++) y[i] = d * x[i];
    const sim_hm_rows *rw = &h->rows;
    for (uint32_t r = 0; r < rw->n; r++) {
        const uint32_t *id = rw->v + 4 * (size_t)r;
        const float *g = rw->g + 12 * (size_t)r;
        float gx = 0.0f;
        for (int j = 0; j < rw->nv[r]; j++) {
            const float *xj = x + 3 * (size_t)id[j];
            gx += g[3 * j] * xj[0] + g[3 * j + 1] * xj[1] + g[3 * j + 2] * xj[2];
        }
        gx *= rw->w[r];
        for (int j = 0; j < rw->nv[r]; j++) {
            float *yj = y + 3 * (size_t)id[j];
            yj[0] += gx * g[3 * j], yj[1] += gx * g[3 * j + 1], yj[2] += gx * g[3 * j + 2];
        }
    }
    const float c = h->damp.c; /* the dampers' dt kd on each pair */
    for (uint32_t i = 0; i < h->damp.n; i++) {
        const uint32_t a = h->damp.a[i], b = h->damp.b[i];
        for (int k = 0; k < 3; k++) {
            const float t = c * (x[3 * a + k] - x[3 * b + k]);
            y[3 * a + k] += t, y[3 * b + k] -= t;
        }
    }
    const sim_hm_cloth *cl = &h->cloth; /* the stretched triangles' (b_u cu cu^T + b_v cv cv^T) I */
    for (uint32_t t = 0; t < cl->ntri; t++) {
        const uint32_t *id = rw->v + 4 * (size_t)(3 * t);
        float cu[3], cv[3], su[3] = { 0 }, sv[3] = { 0 };
        sim_hm_bw_coefficients(cl->tri_c + 4 * (size_t)t, cu, cv);
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++) su[k] += cu[j] * x[3 * id[j] + k], sv[k] += cv[j] * x[3 * id[j] + k];
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++) y[3 * id[j] + k] += cl->tri_b[2 * t] * cu[j] * su[k] + cl->tri_b[2 * t + 1] * cv[j] * sv[k];
    }
}

/* sqrt(sum of a_i^2) over the free vertices' rows. */
static double free_norm(const sim_hm *h, const float *a)
{
    double s = 0.0;
    for (uint32_t i = 0; i < h->n; i++)
        if (!h->fixed[i])
            for (int k = 0; k < 3; k++) s += (double)a[3 * i + k] * a[3 * i + k];
    return sqrt(s);
}

/* The norm over the free rows of the implicit system's residual rhs - A x (by the matrix-free
 * product); y and res are scratch of 3 n floats. */
static double residual_norm(sim_hm *h, const float *x, float *y, float *res)
{
    matrix_free_apply(h, x, y);
    for (size_t i = 0; i < 3 * (size_t)h->n; i++) res[i] = h->rhs[i] - y[i];
    return free_norm(h, res);
}

/* E = 1/2 sum of the squared conditions of the triangle (rest frame c, area a) at x (9 floats) or,
 * with c NULL, of the bend (theta - theta0) at x (12 floats), in double; f gets -dE/dx from the
 * analytic gradients when not NULL. */
static double bw_energy(const float *x, const float *c, float a, float theta0, float *f)
{
    if (c) {
        float C[3], g[3][9];
        sim_hm_bw_stretch_shear(x, x + 3, x + 6, c, a, C, g);
        if (f)
            for (int i = 0; i < 9; i++) f[i] = -(C[0] * g[0][i] + C[1] * g[1][i] + C[2] * g[2][i]);
        return 0.5 * ((double)C[0] * C[0] + (double)C[1] * C[1] + (double)C[2] * C[2]);
    }
    float theta, g[12];
    assert_true(sim_hm_bw_bend(x, x + 3, x + 6, x + 9, &theta, g));
    const double C = (double)theta - theta0;
    if (f)
        for (int i = 0; i < 12; i++) f[i] = (float)(-C * g[i]);
    return 0.5 * C * C;
}

/* The largest difference between f and minus the central differences of bw_energy over the n
 * coordinates of x, relative to f's largest. */
static double bw_gradient_error(float *x, int n, const float *c, float a, float theta0)
{
    float f[12];
    bw_energy(x, c, a, theta0, f);
    double diff = 0.0, ref = 0.0;
    for (int i = 0; i < n; i++) {
        const float x0 = x[i], e = 2e-5f;
        x[i] = x0 + e;
        const double ep = bw_energy(x, c, a, theta0, NULL);
        x[i] = x0 - e;
        const double em = bw_energy(x, c, a, theta0, NULL);
        x[i] = x0;
        diff = fmax(diff, fabs(f[i] + (ep - em) / (2.0 * e))), ref = fmax(ref, fabs(f[i]));
    }
    return diff / ref;
}

/* Baraff and Witkin's stretch and shear of a stretched and sheared triangle and the bend of a
 * folded pair: their forces -C dC/dx are minus the numerical gradient of the energy C^2 / 2, the
 * rest frame gives C = 0 at rest, and the bend's angle is 0 flat. */
static void test_bw_forces_are_energy_gradients(void **state)
{
    (void)state;
    const float p[9] = { 0.0f, 0.0f, 0.0f, 0.012f, 0.001f, 0.0f, 0.002f, 0.009f, 0.003f };
    const float along[3] = { 1.0f, 0.2f, 0.0f };
    float c[4], a, C[3], g[3][9];
    assert_true(sim_hm_bw_rest_triangle(p, p + 3, p + 6, along, c, &a));
    sim_hm_bw_stretch_shear(p, p + 3, p + 6, c, a, C, g);
    for (int k = 0; k < 3; k++) assert_true(fabsf(C[k]) < 1e-4f * a);
    float x[9];
    for (int i = 0; i < 3; i++) { /* stretched 20 % along x, sheared in y by z, moved */
        x[3 * i] = 1.2f * p[3 * i] + 0.3f * p[3 * i + 1] + 0.1f;
        x[3 * i + 1] = 0.7f * p[3 * i + 1] + 0.4f * p[3 * i + 2];
        x[3 * i + 2] = p[3 * i + 2] + 0.2f * p[3 * i];
    }
    sim_hm_bw_stretch_shear(x, x + 3, x + 6, c, a, C, g);
    print_message("deformed triangle: C = %.3g %.3g %.3g of area %.3g\n", (double)C[0], (double)C[1], (double)C[2], (double)a);
    assert_true(fabsf(C[0]) > 0.05f * a && fabsf(C[1]) > 0.05f * a && fabsf(C[2]) > 0.05f * a);
    const double tri = bw_gradient_error(x, 9, c, a, 0.0f);
    float flat[12] = { 0.0f, 0.01f, 0.0f, 0.0f, -0.01f, 0.0f, 0.0f, 0.0f, -0.005f, 0.0f, 0.0f, 0.005f };
    float theta, gb[12];
    assert_true(sim_hm_bw_bend(flat, flat + 3, flat + 6, flat + 9, &theta, gb));
    assert_true(fabsf(theta) < 1e-6f);
    float bent[12] = { 0.004f, 0.009f, 0.001f, 0.006f, -0.008f, 0.002f, 0.0f, 0.0f, -0.005f, 0.001f, 0.0f, 0.005f };
    const double bend = bw_gradient_error(bent, 12, NULL, 0.0f, 0.1f);
    assert_true(sim_hm_bw_bend(bent, bent + 3, bent + 6, bent + 9, &theta, gb));
    print_message("BW forces against the energy's numerical gradient: stretch and shear %.2e, bend %.2e (angle %.3f)\n", tri,
                  bend, (double)theta);
    assert_true(fabsf(theta) > 0.5f);
    assert_true(tri < 2e-3 && bend < 2e-3);
}

/* The block-sparse system the CG iterates on is the one the condition rows', the stretched
 * triangles' and the pair dampers' terms give: its product equals the matrix-free one on a
 * random vector. */
static void test_assembly_matches_matrix_free(void **state)
{
    (void)state;
    hm_run r;
    sim_hm *h = moved_run(&r, false);
    /* every kind of row carries a weight: triangles (3 vertices), bends and tetrahedra (4) */
    const sim_hm_rows *rw = &h->rows;
    assert_true(rw->bend0 > 0 && rw->tet0 > rw->bend0 && rw->n > rw->tet0);
    assert_true(rw->w[2] > 0.0f && rw->w[rw->bend0] > 0.0f && rw->w[rw->tet0] > 0.0f);
    uint32_t tense = 0; /* and the stretched triangles' second derivative */
    for (uint32_t t = 0; t < h->cloth.ntri; t++) tense += h->cloth.tri_b[2 * t] > 0.0f;
    assert_true(tense > 0 && tense < h->cloth.ntri);
    const size_t n3 = 3 * (size_t)h->n;
    float *x = malloc(n3 * sizeof *x), *a = malloc(n3 * sizeof *a), *b = malloc(n3 * sizeof *b);
    assert_true(x && a && b);
    uint32_t seed = 17;
    for (size_t i = 0; i < n3; i++) x[i] = lcg(&seed);
    sim_hm_bsr_apply(&h->bsr, x, a);
    matrix_free_apply(h, x, b);
    double diff = 0.0, ref = 0.0;
    for (size_t i = 0; i < n3; i++) diff = fmax(diff, fabs((double)a[i] - b[i])), ref = fmax(ref, fabs((double)b[i]));
    print_message("assembled vs matrix-free product: max difference %.2e of max %.3g\n", diff / ref, ref);
    assert_true(diff <= 1e-5 * ref);
    free(x), free(a), free(b);
    close_run(&r);
}

/* moved_run(r, true) with the implicit system of a 1/60 s step under gravity assembled. */
static sim_hm *gravity_system(hm_run *r)
{
    sim_hm *h = moved_run(r, true);
    const float accel[3] = { 0.0f, -9.81f, 0.0f };
    sim_hm_forces(h, accel, 1.0f / 60.0f);
    return h;
}

/* The implicit step's CG (symmetric Gauss-Seidel in Eisenstat's form, warm start) solves the
 * system: at a tight tolerance the residual on the free rows (by the matrix-free product) is
 * tiny against the cold start's, the fixed rows keep their prescribed values, and a second solve
 * of the same system starts from the first's solution (less than half the iterations). */
static void test_cg_solves_system(void **state)
{
    (void)state;
    hm_run r;
    sim_hm *h = gravity_system(&r);
    const size_t n3 = 3 * (size_t)h->n;
    float *y = malloc(n3 * sizeof *y), *res = malloc(n3 * sizeof *res);
    assert_true(y && res);
    uint32_t seed = 5;
    memset(h->fixed, 0, h->n);
    for (uint32_t i = 0; i < h->n; i++)
        if (i % h->nlayers == 0 || i % 7 == 3) { /* the roots and a few more */
            h->fixed[i] = 1;
            for (int k = 0; k < 3; k++) h->z[3 * i + k] = 0.01f * lcg(&seed);
        }
    for (size_t i = 0; i < n3; i++) h->vn[i] = 0.0f; /* the cold start: the residual of vn = z on the fixed rows, 0 elsewhere */
    for (uint32_t i = 0; i < h->n; i++)
        for (int k = 0; k < 3; k++) res[3 * i + k] = h->fixed[i] ? h->z[3 * i + k] : 0.0f;
    const double cold = residual_norm(h, res, y, res);
    const int it = sim_hm_cg(h);
    for (uint32_t i = 0; i < h->n; i++)
        if (h->fixed[i])
            for (int k = 0; k < 3; k++) assert_true(h->vn[3 * i + k] == h->z[3 * i + k]);
    const double rel = residual_norm(h, h->vn, y, res) / cold;
    const int again = sim_hm_cg(h);
    const double rel2 = residual_norm(h, h->vn, y, res) / cold;
    print_message("implicit CG: %d iterations, residual %.2e of the cold start's; again from it: %d iterations, %.2e\n", it,
                  rel, again, rel2);
    assert_true(it > 0 && it < 1000);
    assert_true(rel < 1e-4);
    assert_true(again < it / 2);
    assert_true(rel2 < 1e-4);
    free(y), free(res);
    close_run(&r);
}

/* Sliding contacts (SIM_HM_SLIDING, normal n): after sim_hm_filter_sliding the same CG solves the
 * partially constrained system (Baraff and Witkin's filter S = I - n n^T): on those rows the
 * velocity along n is the prescribed z's, and the residual of the unfiltered system (by the
 * matrix-free product) is left only along n there (the contact impulse), which the rows' kept
 * n^T A and n . rhs give back; on the free rows it is tiny. */
static void test_cg_filters_sliding_rows(void **state)
{
    (void)state;
    hm_run r;
    sim_hm *h = gravity_system(&r);
    const size_t n3 = 3 * (size_t)h->n;
    float *y = malloc(n3 * sizeof *y), *res = malloc(n3 * sizeof *res), *rhs = malloc(n3 * sizeof *rhs);
    assert_true(y && res && rhs);
    uint32_t seed = 11, sliding = 0;
    memset(h->fixed, 0, h->n);
    memset(h->stick, 0, h->n);
    for (uint32_t i = 0; i < h->n; i++) {
        for (int k = 0; k < 3; k++) h->z[3 * i + k] = 0.01f * lcg(&seed);
        if (i % h->nlayers == 0) h->fixed[i] = 1;
        else if (i % 5 == 2) {
            float *n = h->normal + 3 * (size_t)i;
            for (int k = 0; k < 3; k++) n[k] = lcg(&seed);
            const float l = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            for (int k = 0; k < 3; k++) n[k] /= l;
            h->stick[i] = SIM_HM_SLIDING, sliding++;
        }
    }
    assert_true(sliding > 10);
    memcpy(rhs, h->rhs, n3 * sizeof *rhs);
    for (uint32_t i = 0; i < h->n; i++) /* the cold start's residual: vn = z on the constrained rows and directions */
        for (int k = 0; k < 3; k++) y[3 * i + k] = h->fixed[i] ? h->z[3 * i + k] : 0.0f;
    for (uint32_t i = 0; i < h->n; i++) {
        if (h->stick[i] != SIM_HM_SLIDING) continue;
        const float *n = h->normal + 3 * (size_t)i, *z = h->z + 3 * (size_t)i;
        const float zn = n[0] * z[0] + n[1] * z[1] + n[2] * z[2];
        for (int k = 0; k < 3; k++) y[3 * i + k] = zn * n[k];
    }
    memcpy(h->vn, y, n3 * sizeof *y);
    matrix_free_apply(h, h->vn, y);
    for (size_t i = 0; i < n3; i++) res[i] = rhs[i] - y[i];
    double cold = 0.0;
    for (uint32_t i = 0; i < h->n; i++) {
        if (h->fixed[i]) continue;
        float *ri = res + 3 * (size_t)i;
        if (h->stick[i] == SIM_HM_SLIDING) {
            const float *n = h->normal + 3 * (size_t)i, rn = n[0] * ri[0] + n[1] * ri[1] + n[2] * ri[2];
            for (int k = 0; k < 3; k++) ri[k] -= rn * n[k];
        }
        for (int k = 0; k < 3; k++) cold += (double)ri[k] * ri[k];
    }
    sim_hm_filter_sliding(h);
    const int it = sim_hm_cg(h);
    matrix_free_apply(h, h->vn, y);
    double worst_n = 0.0, worst_f = 0.0, free2 = 0.0;
    for (uint32_t i = 0; i < h->n; i++) {
        if (h->fixed[i]) continue;
        const float *vi = h->vn + 3 * (size_t)i, *yi = y + 3 * (size_t)i, *bi = rhs + 3 * (size_t)i;
        double ri[3];
        for (int k = 0; k < 3; k++) ri[k] = (double)bi[k] - yi[k];
        if (h->stick[i] == SIM_HM_SLIDING) {
            const float *n = h->normal + 3 * (size_t)i, *z = h->z + 3 * (size_t)i;
            worst_n = fmax(worst_n, fabs((vi[0] - z[0]) * n[0] + (vi[1] - z[1]) * n[1] + (vi[2] - z[2]) * n[2]));
            const double rn = ri[0] * n[0] + ri[1] * n[1] + ri[2] * n[2];
            double fn = -h->nrhs[i];
            for (uint32_t k = h->bsr.row[i]; k < h->bsr.row[i + 1]; k++) {
                const float *nr = h->nrow + 3 * (size_t)k, *x = h->vn + 3 * (size_t)h->bsr.col[k];
                fn += (double)nr[0] * x[0] + (double)nr[1] * x[1] + (double)nr[2] * x[2];
            }
            worst_f = fmax(worst_f, fabs(fn + rn) / (1e-3 + fabs(rn)));
            for (int k = 0; k < 3; k++) ri[k] -= rn * n[k];
        }
        for (int k = 0; k < 3; k++) free2 += ri[k] * ri[k];
    }
    const double rel = sqrt(free2 / cold);
    print_message("filtered CG: %u sliding rows, %d iterations, filtered residual %.2e of the cold start's, "
                  "normal velocity error %.2e m/s, normal impulse error %.2e\n", sliding, it, rel, worst_n, worst_f);
    assert_true(it > 0 && it < 1000);
    assert_true(rel < 1e-3);
    assert_true(worst_n < 1e-5); /* float rounding over the iterations: 4e-8 m a 1/60 s substep */
    assert_true(worst_f < 1e-3);
    free(y), free(res), free(rhs);
    close_run(&r);
}

/* The deformation minimization reaches the minimum of sum |(x_i - x_j) - (ref_i - ref_j)|^2 over
 * the mesh edges with the moved vertices held: the gradient on the free rows vanishes. The edges'
 * neighbour lists are symmetric and ascending. */
static void test_deform_min_solves(void **state)
{
    (void)state;
    hm_run r;
    sim_hm *h = moved_run(&r, true);
    const sim_hm_edges *e = &h->edges;
    assert_int_equal(e->row[h->n], 2 * e->n);
    for (uint32_t i = 0; i < h->n; i++)
        for (uint32_t k = e->row[i]; k < e->row[i + 1]; k++) {
            const uint32_t j = e->nb[k];
            assert_true(j != i && (k == e->row[i] || e->nb[k - 1] < j));
            bool back = false;
            for (uint32_t m = e->row[j]; m < e->row[j + 1]; m++) back |= e->nb[m] == i;
            assert_true(back);
        }
    const size_t n3 = 3 * (size_t)h->n;
    float *ref = malloc(n3 * sizeof *ref), *g = malloc(n3 * sizeof *g);
    assert_true(ref && g);
    memcpy(ref, h->x, n3 * sizeof *ref);
    uint32_t seed = 9;
    memset(h->fixed, 0, h->n);
    for (uint32_t i = 0; i < h->n; i++)
        if (i % h->nlayers == 0) h->fixed[i] = 1;
        else if (h->surface[i] && i % 3 == 0) { /* pushed surface vertices */
            h->fixed[i] = 2;
            for (int k = 0; k < 3; k++) h->x[3 * i + k] += 0.005f * lcg(&seed);
        }
    double g0 = -1.0;
    for (int pass = 0; pass < 2; pass++) {
        /* g = the objective's gradient / 2 = sum over i's edges of (x_i - x_j) - (ref_i - ref_j) */
        for (uint32_t i = 0; i < h->n; i++)
            for (int k = 0; k < 3; k++) {
                double s = 0.0;
                for (uint32_t m = e->row[i]; m < e->row[i + 1]; m++) {
                    const uint32_t j = e->nb[m];
                    s += ((double)h->x[3 * i + k] - h->x[3 * j + k]) - ((double)ref[3 * i + k] - ref[3 * j + k]);
                }
                g[3 * i + k] = (float)s;
            }
        if (pass == 0) {
            g0 = free_norm(h, g);
            sim_hm_deform_min(h, ref);
        }
    }
    const double rel = free_norm(h, g) / g0;
    print_message("deformation minimization: gradient %.2e of the start's\n", rel);
    assert_true(g0 > 0.0 && rel < 1e-4);
    free(ref), free(g);
    close_run(&r);
}

/* How far from the head's origin a vertex of the default procedural mesh may be while the hair
 * moves (at rest the farthest tip is about 0.25 m away), metres. */
#define MOTION_REACH 0.5
/* Seconds of a still head after the violent script within which the mesh must come to rest (the
 * project's stillness bound, issue 13), and how long after that it is watched. */
#define REST_AFTER_VIOLENT 3.0
#define REST_WATCH 1.0

/* The largest distance of a vertex of x from head's origin; fails on a value that is not finite. */
static double reach(const hm_run *r, const float *x, core_xform head)
{
    double worst = 0.0;
    for (uint32_t i = 0; i < 3 * r->nv; i++) assert_true(isfinite(x[i]));
    for (uint32_t i = 0; i < r->nv; i++) {
        const float o[3] = { head.pos.x, head.pos.y, head.pos.z };
        worst = fmax(worst, dist(x + 3 * i, o));
    }
    return worst;
}

/* A run on the procedural mesh of `style` at the benchmark's size (3 x 3 patches, 9 layers). */
static void open_run_style(hm_run *r, groom_style style, bool colliders, const sim_params *p)
{
    const groom_hairmesh_desc d = { .style = style, .nlayers = 9 };
    open_run_desc(r, &d, colliders, 0.0f, p);
}

/* Every procedural style (straight, wavy, curly: thin sheets with a few sliver corner tetrahedra)
 * under the codec benchmark's gentle head motion, which starts with a jump of the head from the
 * identity to its first pose (2 s): finite, every vertex within MOTION_REACH of the head after
 * the first half second, no nan reset; with and without the default colliders. The wavy and curly
 * meshes exploded within two frames when the implicit step solved for the velocity change from
 * dv = 0 (see sim_hm_forces). */
static void test_every_style_gentle_motion(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    for (int run = 0; run < 6; run++) {
        const groom_style style = (groom_style)(run / 2);
        const bool colliders = run % 2;
        hm_run r;
        open_run_style(&r, style, colliders, &p);
        double worst = 0.0;
        for (int f = 0; f < 120; f++) {
            const codec_sim_info c = codec_synth_sim(f * (double)p.dt, (uint64_t)f, CODEC_SYNTH_GENTLE);
            const core_xform head = { core_v3(c.head_pos[0], c.head_pos[1], c.head_pos[2]),
                                      { c.head_rot[0], c.head_rot[1], c.head_rot[2], c.head_rot[3] } };
            sim_set_motion(&r.s, head);
            steps(&r, 1);
            mesh_now(&r, r.x);
            const double w = reach(&r, r.x, head);
            if (f >= 30) worst = fmax(worst, w);
        }
        sim_stats st;
        sim_get_stats(&r.s, &st);
        print_message("%s%s, gentle motion: farthest vertex %.3f m from the head\n", groom_style_name(style),
                      colliders ? " with colliders" : "", worst);
        assert_int_equal(st.nan_resets, 0);
        assert_true(worst <= MOTION_REACH);
        close_run(&r);
    }
}

/* Every procedural style under the violent test script (2 s, simcheck_rest_head), then a still
 * head: without colliders, with the default ones (the head ellipsoid), and with a distance grid
 * as well (simcheck_sphere_sdf, the collision mesh's path): finite, every vertex within
 * MOTION_REACH of the head, no nan reset, and at rest REST_AFTER_VIOLENT s after the stop: p99.9
 * of every frame's displacement within REST_P999 from then on for REST_WATCH s. Prints when the
 * displacement last exceeded REST_P999. Main settled 4.9-5.1 s after the stop without colliders
 * (the springs' dampers acted only along the springs: nothing damped the swinging but the air
 * drag) and never with them (vertices in contact crept 0.01-0.02 mm a frame: pushed out after
 * each solve that moved them in). */
/* Runs the violent test script (2 s, simcheck_rest_head) on the procedural mesh of `style` with
 * colliders of `kind` (as open_run_desc) under p, then REST_AFTER_VIOLENT + REST_WATCH s of a still
 * head. Returns the settle time: seconds after the stop until the last frame whose p99.9
 * displacement exceeds REST_P999; *rest gets the worst p99.9 from REST_AFTER_VIOLENT s on and
 * *worst the farthest vertex from the head. Fails on a value that is not finite or a nan reset. */
static double violent_settle(groom_style style, int kind, const sim_params *p, double *rest, double *worst)
{
    const int moving = 120, stop = moving + 15; /* the head is still 0.25 s after the script */
    const int from = stop + (int)lround(REST_AFTER_VIOLENT * 60.0), frames = from + (int)lround(REST_WATCH * 60.0);
    hm_run r;
    const groom_hairmesh_desc d = { .style = style, .nlayers = 9 };
    open_run_desc(&r, &d, kind, 0.0f, p);
    double *dd = malloc(sizeof *dd * r.nv);
    assert_non_null(dd);
    mesh_now(&r, r.x);
    double settle = 0.0;
    *worst = 0.0, *rest = 0.0;
    for (int f = 0; f < frames; f++) {
        const core_xform head = simcheck_rest_head((f + 1) * (double)p->dt, moving * (double)p->dt);
        sim_set_motion(&r.s, head);
        memcpy(r.prev, r.x, 12 * (size_t)r.nv);
        steps(&r, 1);
        mesh_now(&r, r.x);
        *worst = fmax(*worst, reach(&r, r.x, head));
        for (uint32_t i = 0; i < r.nv; i++) dd[i] = dist(r.x + 3 * i, r.prev + 3 * i);
        qsort(dd, r.nv, sizeof *dd, cmp_double);
        const double p999 = dd[(size_t)(0.999 * (r.nv - 1))];
        if (f >= stop && p999 > REST_P999) settle = (f + 1 - stop) * (double)p->dt;
        if (f >= from) *rest = simcheck_worse(*rest, p999);
    }
    sim_stats st;
    sim_get_stats(&r.s, &st);
    assert_int_equal(st.nan_resets, 0);
    free(dd);
    close_run(&r);
    return settle;
}

static const char *const collider_kinds[3] = { "no colliders", "head ellipsoid", "head ellipsoid and distance grid" };

/* Every procedural style under the violent test script (2 s, simcheck_rest_head), then a still
 * head: without colliders, with the default ones (the head ellipsoid), and with a distance grid
 * as well (simcheck_sphere_sdf, the collision mesh's path): finite, every vertex within
 * MOTION_REACH of the head, no nan reset, and at rest REST_AFTER_VIOLENT s after the stop: p99.9
 * of every frame's displacement within REST_P999 from then on for REST_WATCH s. Prints when the
 * displacement last exceeded REST_P999. Main settled 4.9-5.1 s after the stop without colliders
 * (the springs' dampers acted only along the springs: nothing damped the swinging but the air
 * drag) and never with them (vertices in contact crept 0.01-0.02 mm a frame: pushed out after
 * each solve that moved them in). */
static void test_every_style_violent_then_rest(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    for (int run = 0; run < 9; run++) {
        const groom_style style = (groom_style)(run / 3);
        const int kind = run % 3;
        double rest, worst;
        const double settle = violent_settle(style, kind, &p, &rest, &worst);
        print_message("%s, %s, violent motion: farthest vertex %.3f m from the head; p99.9 at most %.3g mm/frame "
                      "%.0f-%.0f s after the stop, last above %.3g mm %.2f s after\n",
                      groom_style_name(style), collider_kinds[kind], worst, rest * 1e3, REST_AFTER_VIOLENT,
                      REST_AFTER_VIOLENT + REST_WATCH, REST_P999 * 1e3, settle);
        assert_true(worst <= MOTION_REACH);
        assert_true(rest <= REST_P999);
    }
}

/* hm_damping at its minimum, the middle of its range and its maximum (the table's, one at a time,
 * the rest at the defaults): every style, without colliders, on the head ellipsoid and with the
 * distance grid as well, rests REST_AFTER_VIOLENT s after the violent script (issue 13); and
 * more damping never settles later (one frame's slack), with the colliders too. Main's range
 * [0, 100] settled in more than 4 s at both ends: at 0 only the air drag damps the swinging, at
 * 100 the soft modes are over-damped and creep back. With the colliders, wavy on the head
 * ellipsoid took 2.83, 2.47 and 2.92 s at 5, 6.5 and 8 while sliding contacts were pushed out
 * after each solve instead of held along their normals in it (2.78, 2.45, 2.40 s since). */
static void test_hm_damping_range_rests_monotonic(void **state)
{
    (void)state;
    size_t count;
    const core_param_info *t = sim_param_table(&count);
    const core_param_info *e = NULL;
    for (size_t i = 0; i < count; i++)
        if (strcmp(t[i].name, "hm_damping") == 0) e = &t[i];
    assert_non_null(e);
    const float v[3] = { (float)e->min, (float)(0.5 * (e->min + e->max)), (float)e->max };
    for (int style = 0; style < 3; style++)
        for (int kind = 0; kind < 3; kind++) {
            double prev = INFINITY;
            for (int i = 0; i < 3; i++) {
                sim_params p;
                sim_params_default(&p);
                p.hm.damping = v[i];
                double rest, worst;
                const double settle = violent_settle((groom_style)style, kind, &p, &rest, &worst);
                print_message("%s, %s, hm_damping %g: last above %.3g mm %.2f s after the stop\n",
                              groom_style_name((groom_style)style), collider_kinds[kind], v[i], REST_P999 * 1e3, settle);
                assert_true(rest <= REST_P999);
                assert_true(settle <= prev + p.dt);
                prev = settle;
            }
        }
}

/* The shared parameters the hair-mesh solver reads (friction, air_drag; test_sim_rest takes their
 * ends under the strand solvers only) at their ends, the others at default: every style on the head ellipsoid and with the distance grid
 * as well (air_drag without colliders too) rests REST_AFTER_VIOLENT s after the violent script (issue 13). At the ends that damp
 * least main missed it: friction 0 (every contact sliding, pushed out after each solve instead
 * of held along its normal in it) settled 3.3 s to never (more than 4 s) after the stop, air_drag 0
 * (only the root prisms' dampers took the swing: see SIM_HM_SWING_DAMPING) 3.7-4.0 s. At its most
 * main damped too much: air_drag 20 over-damped the mesh's return to its rest shape, which crept
 * back 3.10-3.40 s after the stop without colliders, up to 3.43 s with them (SIM_HM_DRAG_CAP). */
static void test_hm_shared_params_rest(void **state)
{
    (void)state;
    static const struct {
        const char *name;
        size_t offset;
        float v;
        bool max;
        int first_kind; /* the collider kinds run: first_kind to 2 (friction needs colliders) */
    } ends[4] = { { "friction", offsetof(sim_params, friction), 0.0f, false, 1 },
                  { "friction", offsetof(sim_params, friction), 1.0f, true, 1 },
                  { "air_drag", offsetof(sim_params, air_drag), 0.0f, false, 0 },
                  { "air_drag", offsetof(sim_params, air_drag), 20.0f, true, 0 } };
    size_t count;
    const core_param_info *t = sim_param_table(&count);
    for (int e = 0; e < 4; e++) {
        bool at_end = false;
        for (size_t i = 0; i < count; i++)
            if (strcmp(t[i].name, ends[e].name) == 0) at_end = ends[e].v == (float)(ends[e].max ? t[i].max : t[i].min);
        assert_true(at_end); /* the table's ends */
        for (int style = 0; style < 3; style++)
            for (int kind = ends[e].first_kind; kind < 3; kind++) {
                sim_params p;
                sim_params_default(&p);
                *(float *)((char *)&p + ends[e].offset) = ends[e].v;
                double rest, worst;
                const double settle = violent_settle((groom_style)style, kind, &p, &rest, &worst);
                print_message("%s, %s, %s %g: p99.9 at most %.3g mm/frame from %.0f s, last above %.3g mm %.2f s after the stop\n",
                              groom_style_name((groom_style)style), collider_kinds[kind], ends[e].name, ends[e].v,
                              rest * 1e3, REST_AFTER_VIOLENT, REST_P999 * 1e3, settle);
                assert_true(worst <= MOTION_REACH);
                assert_true(rest <= REST_P999);
            }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_interface),
        cmocka_unit_test(test_rest),
        cmocka_unit_test(test_sag_same_at_any_step),
        cmocka_unit_test(test_bend_param_changes_sag),
        cmocka_unit_test(test_hm_params_at_extremes),
        cmocka_unit_test(test_collapse_recovers),
        cmocka_unit_test(test_fast_motion_recovers),
        cmocka_unit_test(test_deform_min_keeps_volume),
        cmocka_unit_test(test_sdf_contact),
        cmocka_unit_test(test_bw_forces_are_energy_gradients),
        cmocka_unit_test(test_assembly_matches_matrix_free),
        cmocka_unit_test(test_cg_solves_system),
        cmocka_unit_test(test_cg_filters_sliding_rows),
        cmocka_unit_test(test_deform_min_solves),
        cmocka_unit_test(test_every_style_gentle_motion),
        cmocka_unit_test(test_every_style_violent_then_rest),
        cmocka_unit_test(test_hm_damping_range_rests_monotonic),
        cmocka_unit_test(test_hm_shared_params_rest),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
