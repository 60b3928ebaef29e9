/* Tests for tests/support/quality.c: each hair quality metric on hand-built strands whose answer
 * is known, so a broken metric (and the strandbench quality figures built on it) fails here. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "support/quality.h"

#define SPACING 0.005f /* between neighbouring strands, m */
#define SEG 0.01f      /* between the vertices of a strand, m */

/* A groom of nx x nz vertical strands hanging down from roots at y = 0 on a square grid of
 * SPACING in x and z, nverts vertices SEG apart; no colliders. The caller frees g. */
static void grid_groom(core_groom *g, uint32_t nx, uint32_t nz, uint32_t nverts)
{
    core_err err;
    memset(g, 0, sizeof *g);
    assert_int_equal(core_groom_alloc(g, nx * nz, nverts, &err), CORE_OK);
    for (uint32_t a = 0; a < nx; a++)
        for (uint32_t b = 0; b < nz; b++)
            for (uint32_t v = 0; v < nverts; v++) {
                float *p = g->pos + 3 * ((size_t)(a * nz + b) * nverts + v);
                p[0] = (float)a * SPACING;
                p[1] = -(float)v * SEG;
                p[2] = (float)b * SPACING;
            }
}

static float *copy_pos(const core_groom *g)
{
    size_t n = 3 * (size_t)g->nstrands * g->nverts;
    float *x = malloc(n * sizeof *x);
    assert_non_null(x);
    memcpy(x, g->pos, n * sizeof *x);
    return x;
}

static void test_displacement_quantile(void **state)
{
    (void)state;
    core_groom g;
    grid_groom(&g, 10, 1, 11); /* 100 non-root vertices */
    float *x = copy_pos(&g);
    double scratch[1000];
    assert_true(quality_displacement_quantile(x, g.pos, g.nstrands, g.nverts, 0.999, scratch) == 0.0);
    x[3 * (3 * 11 + 5) + 0] += 0.002f; /* one vertex moved 2 mm: the top 1% */
    double d = quality_displacement_quantile(x, g.pos, g.nstrands, g.nverts, 0.999, scratch);
    assert_float_equal(d, 0.002, 1e-9);
    assert_true(quality_displacement_quantile(x, g.pos, g.nstrands, g.nverts, 0.5, scratch) == 0.0);
    /* a moved root is not hair that moves (roots follow the head) */
    float *y = copy_pos(&g);
    y[3 * (4 * 11) + 1] += 0.01f;
    assert_true(quality_displacement_quantile(y, g.pos, g.nstrands, g.nverts, 0.999, scratch) == 0.0);
    y[3 * (4 * 11 + 2) + 1] = NAN;
    assert_true(isnan(quality_displacement_quantile(y, g.pos, g.nstrands, g.nverts, 0.999, scratch)));
    free(y);
    free(x);
    core_groom_free(&g);

    grid_groom(&g, 10, 10, 11); /* 1000 non-root vertices: p99.9 is the 999th smallest */
    x = copy_pos(&g);
    x[3 * 7 + 2] += 0.003f;
    assert_true(quality_displacement_quantile(x, g.pos, g.nstrands, g.nverts, 0.999, scratch) == 0.0);
    x[3 * 500 + 1] -= 0.004f; /* two of 1000 moved: the 999th is the smaller */
    assert_float_equal(quality_displacement_quantile(x, g.pos, g.nstrands, g.nverts, 0.999, scratch), 0.003, 1e-9);
    assert_float_equal(quality_displacement_quantile(x, g.pos, g.nstrands, g.nverts, 1.0, scratch), 0.004, 1e-9);
    free(x);
    core_groom_free(&g);
}

static void test_segment_error(void **state)
{
    (void)state;
    core_groom g;
    grid_groom(&g, 3, 2, 6);
    float *x = copy_pos(&g);
    assert_true(quality_segment_error_max(&g, x, 0.0) == 0.0);
    x[3 * (4 * 6 + 5) + 1] -= 0.1f * SEG; /* the tip segment of strand 4 stretched by 10% */
    assert_float_equal(quality_segment_error_max(&g, x, 0.0), 0.1, 1e-5);
    x[3 * (1 * 6 + 5) + 1] += 0.25f * SEG; /* strand 1's tip segment compressed by 25% */
    assert_float_equal(quality_segment_error_max(&g, x, 0.0), 0.25, 1e-5);
    x[3 * 2 + 0] = NAN;
    assert_true(isnan(quality_segment_error_max(&g, x, 0.0)));
    free(x);
    core_groom_free(&g);
}

static void test_penetration(void **state)
{
    (void)state;
    core_groom g;
    grid_groom(&g, 2, 1, 4);
    float *x = copy_pos(&g);
    assert_true(quality_penetration_max(&g, core_xform_identity(), x) == 0.0); /* no colliders */
    g.ncolliders = 1;
    g.colliders[0] = (core_collider){ .kind = CORE_COLLIDER_SPHERE, .a = { 0.0f, 0.0f, 0.0f }, .radius = 0.1f };
    core_xform h = core_xform_identity();
    h.pos = core_v3(1.0f, 2.0f, 3.0f);
    h.rot = core_q_axis_angle(core_v3(0, 1, 0), 0.7f);
    for (size_t i = 0; i < 3 * 8; i += 3) { /* far from the moved sphere */
        x[i] = 5.0f;
        x[i + 1] = 5.0f;
    }
    assert_true(quality_penetration_max(&g, h, x) == 0.0);
    /* vertex 2 of strand 1, 98 mm from the centre: 2 mm inside */
    float *p = x + 3 * (4 + 2);
    p[0] = 1.0f + 0.098f;
    p[1] = 2.0f;
    p[2] = 3.0f;
    assert_float_equal(quality_penetration_max(&g, h, x), 0.002, 1e-6);
    /* a root deeper inside does not count: roots are placed by the groom */
    x[0] = 1.0f;
    x[1] = 2.0f;
    x[2] = 3.0f;
    assert_float_equal(quality_penetration_max(&g, h, x), 0.002, 1e-6);

    /* capsule along x from -0.1 to 0.1, radius 0.05: a point 3 mm inside its side */
    core_collider cap = { .kind = CORE_COLLIDER_CAPSULE, .a = { -0.1f, 0, 0 }, .b = { 0.1f, 0, 0 }, .radius = 0.05f };
    assert_float_equal(quality_collider_depth(&cap, core_xform_identity(), core_v3(0.05f, 0.047f, 0)), 0.003, 1e-6);
    assert_float_equal(quality_collider_depth(&cap, core_xform_identity(), core_v3(0.16f, 0, 0)), -0.01, 1e-6);
    /* ellipsoid with semi-axes 0.08, 0.10, 0.095: 2 mm inside on the y axis and on the x axis;
     * rotated a quarter turn about z, its x axis lies along y */
    core_collider ell = { .kind = CORE_COLLIDER_ELLIPSOID, .radii = { 0.08f, 0.10f, 0.095f }, .rot = core_q_identity() };
    assert_float_equal(quality_collider_depth(&ell, core_xform_identity(), core_v3(0, 0.098f, 0)), 0.002, 1e-6);
    assert_float_equal(quality_collider_depth(&ell, core_xform_identity(), core_v3(-0.078f, 0, 0)), 0.002, 1e-6);
    assert_float_equal(quality_collider_depth(&ell, core_xform_identity(), core_v3(0, 0, 0.1f)), -0.005, 1e-6);
    assert_float_equal(quality_collider_depth(&ell, core_xform_identity(), core_v3(0, 0, 0)), 0.08, 1e-6);
    ell.rot = core_q_axis_angle(core_v3(0, 0, 1), 1.5707963f);
    assert_float_equal(quality_collider_depth(&ell, core_xform_identity(), core_v3(0, 0.078f, 0)), 0.002, 1e-5);
    /* the deepest collider wins */
    g.ncolliders = 2;
    g.colliders[1] = (core_collider){ .kind = CORE_COLLIDER_SPHERE, .a = { 0.0f, 0.0f, 0.0f }, .radius = 0.105f };
    assert_float_equal(quality_penetration_max(&g, h, x), 0.007, 1e-6);
    p[1] = NAN;
    assert_true(isnan(quality_penetration_max(&g, h, x)));
    free(x);
    core_groom_free(&g);
}

/* The mesh's distance grid counts a vertex's depth beyond the depth its rest position is
 * authored at (the groom touches the body); a vertex authored outside gets no allowance. */
static void test_penetration_authored_depth(void **state)
{
    (void)state;
    core_err err;
    core_groom g;
    grid_groom(&g, 2, 1, 4); /* strands hanging from y = 0, vertices 10 mm apart */
    g.sdf = calloc(1, sizeof *g.sdf);
    assert_non_null(g.sdf);
    const uint32_t dims[3] = { 3, 3, 3 };
    assert_int_equal(core_sdf_alloc(g.sdf, dims, core_v3(-0.01f, -0.04f, -0.01f), 0.02f, &err), CORE_OK);
    for (uint32_t k = 0; k < 3; k++) /* the body is below y = -15 mm */
        for (uint32_t j = 0; j < 3; j++)
            for (uint32_t i = 0; i < 3; i++) g.sdf->d[i + 3 * (j + 3 * k)] = -0.04f + 0.02f * (float)j + 0.015f;
    float *x = copy_pos(&g);
    /* vertices 2 and 3 are authored 5 and 15 mm inside: where authored, nothing counts */
    assert_true(quality_penetration_max(&g, core_xform_identity(), x) == 0.0);
    x[3 * 2 + 1] = -0.021f; /* 1 mm deeper than authored */
    assert_float_equal(quality_penetration_max(&g, core_xform_identity(), x), 0.001, 1e-6);
    x[3 * 1 + 1] = -0.017f; /* authored 5 mm outside, now 2 mm inside */
    assert_float_equal(quality_penetration_max(&g, core_xform_identity(), x), 0.002, 1e-6);
    free(x);
    core_groom_free(&g);
}

static void test_shape_deviation(void **state)
{
    (void)state;
    core_groom g;
    grid_groom(&g, 2, 2, 5);
    assert_float_equal(quality_mean_strand_length(&g), 4.0 * SEG, 1e-7);
    core_xform h = core_xform_identity();
    h.pos = core_v3(0.3f, -0.2f, 0.1f);
    h.rot = core_q_axis_angle(core_v3(1, 0, 0), 0.5f);
    float *x = copy_pos(&g);
    for (size_t i = 0; i < 3 * 20; i += 3) { /* the authored groom carried by the head */
        core_vec3 w = core_xform_point(h, core_v3(g.pos[i], g.pos[i + 1], g.pos[i + 2]));
        x[i] = w.x;
        x[i + 1] = w.y;
        x[i + 2] = w.z;
    }
    assert_float_equal(quality_shape_deviation(&g, h, x), 0.0, 1e-6);
    /* every non-root vertex 1 cm off: 0.01 m over a 0.04 m strand */
    for (size_t i = 0; i < 20; i++)
        if (i % 5 != 0) x[3 * i + 2] += 0.01f;
    assert_float_equal(quality_shape_deviation(&g, h, x), 0.25, 1e-5);
    free(x);
    core_groom_free(&g);
}

static void test_tips_above_roots(void **state)
{
    (void)state;
    core_groom g;
    grid_groom(&g, 4, 1, 3); /* every strand hangs down */
    assert_true(quality_tips_above_roots(g.pos, g.nstrands, g.nverts) == 0.0);
    g.pos[3 * (1 * 3 + 2) + 1] = 0.001f; /* strand 1's tip just above its root */
    assert_float_equal(quality_tips_above_roots(g.pos, g.nstrands, g.nverts), 0.25, 1e-12);
    g.pos[3 * (3 * 3 + 2) + 1] = 0.0f; /* level with the root: not above */
    assert_float_equal(quality_tips_above_roots(g.pos, g.nstrands, g.nverts), 0.25, 1e-12);
    g.pos[3 * (2 * 3 + 2) + 1] = 0.5f;
    assert_float_equal(quality_tips_above_roots(g.pos, g.nstrands, g.nverts), 0.5, 1e-12);
    core_groom_free(&g);
}

/* The brute-force mean distance to the nearest vertex of another strand. */
static double nn_brute(const float *x, uint32_t ns, uint32_t nv)
{
    size_t n = (size_t)ns * nv;
    double sum = 0.0;
    for (size_t i = 0; i < n; i++) {
        double best = INFINITY;
        for (size_t j = 0; j < n; j++) {
            if (i / nv == j / nv) continue;
            double dx = (double)x[3 * i] - x[3 * j], dy = (double)x[3 * i + 1] - x[3 * j + 1],
                   dz = (double)x[3 * i + 2] - x[3 * j + 2];
            double d = sqrt(dx * dx + dy * dy + dz * dz);
            if (d < best) best = d;
        }
        sum += best;
    }
    return sum / (double)n;
}

static void test_nearest_other_strand(void **state)
{
    (void)state;
    core_err err;
    core_groom g;
    double d;
    grid_groom(&g, 3, 3, 8); /* the nearest other strand is one grid spacing away everywhere */
    assert_int_equal(quality_nn_other_strand_mean(g.pos, g.nstrands, g.nverts, &d, &err), CORE_OK);
    assert_float_equal(d, SPACING, 1e-7);
    core_groom_free(&g);
    grid_groom(&g, 1, 1, 8);
    assert_int_equal(quality_nn_other_strand_mean(g.pos, g.nstrands, g.nverts, &d, &err), CORE_EINVAL);
    core_groom_free(&g);

    /* strands far apart compared with their segments (many empty cells to search) and a
     * jittered groom, both against brute force */
    grid_groom(&g, 6, 5, 7);
    float *x = copy_pos(&g);
    for (size_t i = 0; i < 3 * (size_t)g.nstrands * g.nverts; i++) x[i] *= (i % 3 == 1) ? 0.02f : 1.0f;
    assert_int_equal(quality_nn_other_strand_mean(x, g.nstrands, g.nverts, &d, &err), CORE_OK);
    assert_float_equal(d, nn_brute(x, g.nstrands, g.nverts), 1e-9);
    unsigned seed = 12345u;
    for (size_t i = 0; i < 3 * (size_t)g.nstrands * g.nverts; i++) {
        seed = seed * 1103515245u + 12345u;
        x[i] = g.pos[i] + 0.004f * ((float)((seed >> 8) & 0xffff) / 65535.0f - 0.5f);
    }
    assert_int_equal(quality_nn_other_strand_mean(x, g.nstrands, g.nverts, &d, &err), CORE_OK);
    assert_float_equal(d, nn_brute(x, g.nstrands, g.nverts), 1e-9);
    x[5] = INFINITY;
    assert_int_equal(quality_nn_other_strand_mean(x, g.nstrands, g.nverts, &d, &err), CORE_OK);
    assert_true(isnan(d));
    free(x);
    core_groom_free(&g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_displacement_quantile), cmocka_unit_test(test_segment_error),
        cmocka_unit_test(test_penetration),           cmocka_unit_test(test_penetration_authored_depth),
        cmocka_unit_test(test_shape_deviation),       cmocka_unit_test(test_tips_above_roots),
        cmocka_unit_test(test_nearest_other_strand),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
