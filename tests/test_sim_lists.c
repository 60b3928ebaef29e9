/* tests: the CPU backend's kept SPH neighbour lists (sim_cpu_sph.c, SPH_SKIN). They are kept while
 * the hair moves together, even far, and searched anew when a pair outside them may have come
 * within h; a grid whose cells share buckets falls back to the bound on each particle's own
 * offset. White box: particles of a sim_cpu are moved between SPH passes taken directly. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "groom/groom.h"
#include "sim/sim.h"
#include "sim/sim_cpu_internal.h"

#define NS 512
#define NV 16

typedef struct fixture {
    core_groom g;
    sim s;
    sim_cpu *c;
} fixture;

/* A straight groom on the CPU backend after a few steps (c->step holds an SPH step's plan). */
static void make(fixture *f, float sph_radius)
{
    core_err err;
    groom_desc gd = { .style = GROOM_STRAIGHT, .nstrands = NS, .nverts = NV };
    if (groom_procedural(&gd, &f->g, &err) != CORE_OK) fail_msg("groom: %s", err.msg);
    sim_params p;
    sim_params_default(&p);
    p.sph_radius = sph_radius;
    sim_desc d = { .backend = SIM_BACKEND_CPU, .threads = 2 };
    if (sim_create(&f->s, &d, &f->g, &p, &err) != CORE_OK) fail_msg("sim_create: %s", err.msg);
    f->c = f->s.self;
    for (int i = 0; i < 4; i++) assert_int_equal(sim_step(&f->s, &err), CORE_OK);
    assert_true(f->c->step.sph_h > 0.0f);
}

static void drop(fixture *f)
{
    sim_destroy(&f->s);
    core_groom_free(&f->g);
}

/* One SPH pass over the current positions; returns whether it searched anew. */
static bool pass(fixture *f)
{
    sim_cpu *c = f->c;
    core_err err;
    const uint64_t before = c->stats.sph_searches;
    assert_int_equal(sim_cpu_sph_pass(c, c->x, c->xe, c->step.sph_inv_since, c->params.dt, c->head, NULL, false, &err),
                     CORE_OK);
    return c->stats.sph_searches > before;
}

static float dist(const sim_cpu *c, size_t i, size_t j)
{
    const float dx = c->x[0][i] - c->x[0][j], dy = c->x[1][i] - c->x[1][j], dz = c->x[2][i] - c->x[2][j];
    return sqrtf(dx * dx + dy * dy + dz * dz);
}

/* Moves particle i by t times the unit vector from it toward particle j. */
static void move_toward(sim_cpu *c, size_t i, size_t j, float t)
{
    const float d = dist(c, i, j);
    for (int k = 0; k < 3; k++) c->x[k][i] += t * (c->x[k][j] - c->x[k][i]) / d;
}

/* A particle of another strand than i's between lo and hi (x h) from it, or SIZE_MAX. */
static size_t other_between(const sim_cpu *c, size_t i, float lo, float hi)
{
    const float h = c->step.sph_h;
    for (size_t j = 0; j < c->n; j++) {
        const float d = dist(c, i, j);
        if (j % c->ns != i % c->ns && d > lo * h && d < hi * h) return j;
    }
    return SIZE_MAX;
}

/* The pass's inputs besides the positions that it also writes: the accelerations (smoothed with
 * what they held) and the held friction. */
typedef struct accel {
    float *a[3], *af;
} accel;

static void accel_copy(const sim_cpu *c, accel *to, float *const from_a[3], const float *from_af)
{
    for (int k = 0; k < 3; k++) memcpy(to->a[k], from_a[k], c->n * sizeof(float));
    memcpy(to->af, from_af, 4 * c->n * sizeof(float));
}

static void accel_alloc(const sim_cpu *c, accel *x)
{
    for (int k = 0; k < 3; k++) assert_non_null(x->a[k] = malloc(c->n * sizeof(float)));
    assert_non_null(x->af = malloc(4 * c->n * sizeof(float)));
}

static void accel_free(accel *x)
{
    for (int k = 0; k < 3; k++) free(x->a[k]);
    free(x->af);
}

/* The whole groom translated by half of h (past SPH_SKIN h / 2, the bound on one particle's own
 * offset): the lists are kept, and the pass gives what a search gives. */
static void test_kept_when_moving_together(void **state)
{
    (void)state;
    fixture f;
    make(&f, 0.0f);
    sim_cpu *c = f.c;
    pass(&f);
    assert_true(sim_cpu_sph_unfolded(&c->sph));
    assert_false(pass(&f)); /* nothing moved */
    const float h = c->step.sph_h;
    for (size_t i = 0; i < c->n; i++) c->x[0][i] += 0.3f * h, c->x[1][i] -= 0.4f * h;
    accel before, kept;
    accel_alloc(c, &before);
    accel_alloc(c, &kept);
    accel_copy(c, &before, c->a, c->af);
    assert_false(pass(&f));
    accel_copy(c, &kept, c->a, c->af);
    accel_copy(c, &(accel){ { c->a[0], c->a[1], c->a[2] }, c->af }, before.a, before.af);
    c->sph.lists_valid = false;
    assert_true(pass(&f));
    double worst = 0.0, scale = 0.0;
    for (int k = 0; k < 3; k++)
        for (size_t i = 0; i < c->n; i++) {
            worst = fmax(worst, fabs((double)c->a[k][i] - (double)kept.a[k][i]));
            scale = fmax(scale, fabs((double)kept.a[k][i]));
        }
    assert_true(scale > 0.0);
    assert_true(worst <= 1e-5 * scale);
    accel_free(&before);
    accel_free(&kept);
    drop(&f);
}

/* One particle moved 0.75 h toward a particle of another strand that was beyond the skin radius
 * at the search (1.45-1.55 h away), so the two are now within h: the offsets of one cell differ
 * by more than SPH_SKIN h, the pair is found and the lists are searched anew. Moved as far in a
 * direction that brings it within h of nobody it was not within the skin radius of, they are
 * kept. */
static void test_search_when_a_pair_comes_near(void **state)
{
    (void)state;
    fixture f;
    make(&f, 0.0f);
    sim_cpu *c = f.c;
    const float h = c->step.sph_h;
    c->sph.lists_valid = false;
    pass(&f); /* searched at these positions */
    assert_true(sim_cpu_sph_unfolded(&c->sph));
    const size_t i = (NV / 2) * (size_t)NS + NS / 2;
    const size_t j = other_between(c, i, 1.45f, 1.55f);
    assert_true(j != SIZE_MAX);
    const float was[3] = { c->x[0][i], c->x[1][i], c->x[2][i] };
    /* first along the strand, back toward the root: only particles already near it lie there */
    const size_t up = i - NS;
    move_toward(c, i, up, 0.6f * h);
    for (size_t k = 0; k < c->n; k++) {
        const float dx = c->x[0][k] - was[0], dy = c->x[1][k] - was[1], dz = c->x[2][k] - was[2];
        if (k % NS != i % NS && dist(c, i, k) < h) assert_true(sqrtf(dx * dx + dy * dy + dz * dz) < 1.4f * h);
    }
    assert_false(pass(&f));
    c->x[0][i] = was[0], c->x[1][i] = was[1], c->x[2][i] = was[2];
    assert_false(pass(&f));
    move_toward(c, i, j, dist(c, i, j) - 0.75f * h);
    assert_true(dist(c, i, j) < h);
    assert_true(pass(&f));
    drop(&f);
}

/* A smoothing length so small that the grid's cells outnumber its buckets: the lists are kept
 * only while each particle's own offset is below SPH_SKIN h / 2, so the translation of
 * test_kept_when_moving_together searches anew. */
static void test_folded_grid_bounds_each_offset(void **state)
{
    (void)state;
    fixture f;
    make(&f, 0.001f); /* the smallest h taken */
    sim_cpu *c = f.c;
    pass(&f);
    assert_false(sim_cpu_sph_unfolded(&c->sph));
    assert_false(pass(&f));
    const float h = c->step.sph_h;
    for (size_t i = 0; i < c->n; i++) c->x[0][i] += 0.1f * h;
    assert_false(pass(&f));
    for (size_t i = 0; i < c->n; i++) c->x[0][i] += 0.2f * h;
    assert_true(pass(&f));
    drop(&f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kept_when_moving_together),
        cmocka_unit_test(test_search_when_a_pair_comes_near),
        cmocka_unit_test(test_folded_grid_bounds_each_offset),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
