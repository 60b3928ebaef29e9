/* tests: the CPU reference solver (invariants, robustness, features, determinism). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "groom/groom.h"
#include "sim/sim.h"
#include "sim/sim_step.h"
#include "support/quality.h"
#include "support/sim_check.h"

typedef struct fixture {
    core_groom groom;
    sim s;
    float *x;
} fixture;

static void make_desc(fixture *f, groom_style style, uint32_t ns, uint32_t nv, const sim_params *p, const sim_desc *d,
                      bool colliders)
{
    core_err err;
    simcheck_groom(&f->groom, style, ns, nv, 7);
    if (!colliders) f->groom.ncolliders = 0;
    core_status st = sim_create(&f->s, d, &f->groom, p, &err);
    if (st != CORE_OK) fail_msg("sim_create: %s", err.msg);
    f->x = malloc(sizeof(float) * 3 * ns * nv);
    assert_non_null(f->x);
}

static void make_style(fixture *f, groom_style style, uint32_t ns, uint32_t nv, const sim_params *p, int threads,
                       bool colliders)
{
    sim_desc d = { .backend = SIM_BACKEND_CPU, .threads = threads };
    make_desc(f, style, ns, nv, p, &d, colliders);
}

static void make(fixture *f, uint32_t ns, uint32_t nv, const sim_params *p, int threads, bool colliders)
{
    make_style(f, GROOM_STRAIGHT, ns, nv, p, threads, colliders);
}

static void drop(fixture *f)
{
    sim_destroy(&f->s);
    core_groom_free(&f->groom);
    free(f->x);
}

static void step(fixture *f)
{
    core_err err;
    if (sim_step(&f->s, &err) != CORE_OK) fail_msg("sim_step: %s", err.msg);
    assert_int_equal(sim_read_positions(&f->s, f->x, &err), CORE_OK);
}

/* Mean distance of every vertex to its rest position under head transform h. */
static double mean_rest_distance(const fixture *f, core_xform h)
{
    size_t n = (size_t)f->groom.nstrands * f->groom.nverts;
    double sum = 0.0;
    for (size_t i = 0; i < 3 * n; i += 3) {
        core_vec3 r = core_xform_point(h, core_v3(f->groom.pos[i], f->groom.pos[i + 1], f->groom.pos[i + 2]));
        float rp[3] = { r.x, r.y, r.z };
        sum += simcheck_dist3(f->x + i, rp);
    }
    return sum / (double)n;
}

static void assert_all_finite(const fixture *f)
{
    size_t n = 3 * (size_t)f->groom.nstrands * f->groom.nverts;
    for (size_t i = 0; i < n; i++)
        if (!isfinite(f->x[i])) fail_msg("position %zu is not finite", i / 3);
}

/* (1) Inextensibility: no colliders, 600 steps of violent head motion. */
static void test_inextensibility(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    fixture f;
    make(&f, 256, 24, &p, 2, false);
    double worst = 0.0;
    for (int i = 0; i < 600; i++) {
        sim_set_motion(&f.s, simcheck_head_motion(i * p.dt, 1.0));
        step(&f);
        worst = simcheck_worse(worst, quality_segment_error_max(&f.groom, f.x, 0.0));
    }
    printf("max relative segment-length error over 600 steps: %.3g\n", worst);
    assert_true(worst <= 1e-4);
    drop(&f);
}

/* (2) Colliders: no vertex inside a collider by more than 1% of its radius after any step. */
static void test_collisions(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    fixture f;
    make(&f, 256, 24, &p, 2, true);
    assert_true(f.groom.ncolliders >= 2);
    double worst = -1.0;
    for (int i = 0; i < 400; i++) {
        core_xform h = simcheck_head_motion(i * p.dt, 1.5);
        sim_set_motion(&f.s, h);
        step(&f);
        worst = simcheck_worse(worst, simcheck_deepest_penetration(&f.groom, h, f.x));
    }
    printf("deepest penetration: %.3g of the collider radius\n", worst);
    assert_true(worst <= 0.01);
    drop(&f);
}

/* (3) Robustness (the hair-mesh paper's test): the hair settles under gravity, then 5 s of
 * head motion at 10x speed, then 3 s of rest: it comes back to its rest pose (the pose it
 * rests in under gravity with the head still) and nothing is NaN. */
static void test_robustness(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    fixture f;
    make(&f, 256, 24, &p, 2, true);
    size_t nverts = (size_t)f.groom.nstrands * f.groom.nverts;
    int settle = (int)lround(3.0 / p.dt), shake = (int)lround(5.0 / p.dt);
    for (int i = 0; i < settle; i++) step(&f);
    float *rest = malloc(sizeof(float) * 3 * nverts);
    memcpy(rest, f.x, sizeof(float) * 3 * nverts);
    double len = simcheck_mean_strand_length(&f.groom), shaken = 0.0;
    for (int i = 0; i < shake; i++) {
        sim_set_motion(&f.s, simcheck_head_motion(i * p.dt, 10.0));
        step(&f);
        assert_all_finite(&f);
        double d = simcheck_mean_distance(f.x, rest, nverts);
        if (d > shaken) shaken = d;
    }
    sim_set_motion(&f.s, core_xform_identity());
    for (int i = 0; i < settle; i++) step(&f);
    assert_all_finite(&f);
    double d = simcheck_mean_distance(f.x, rest, nverts);
    printf("10x shaking moved the hair up to %.4f m (mean); after 3 s rest: %.4f m = %.2f%% of strand length\n",
           shaken, d, 100.0 * d / len);
    assert_true(shaken > 0.1 * len); /* the motion really was violent */
    assert_true(d < 0.05 * len);
    free(rest);
    drop(&f);
}

static double settle_distance(bool shape)
{
    sim_params p;
    sim_params_default(&p);
    p.shape = shape;
    p.sph = false;
    fixture f;
    make_style(&f, GROOM_CURLY, 256, 24, &p, 2, true);
    for (int i = 0; i < 180; i++) step(&f);
    double d = mean_rest_distance(&f, core_xform_identity());
    drop(&f);
    return d;
}

/* (4) Shape preservation holds the settled hair closer to its styled rest shape (curls stay
 * curled instead of being pulled straight by gravity). */
static void test_shape_preservation(void **state)
{
    (void)state;
    double on = settle_distance(true), off = settle_distance(false);
    printf("settled mean distance to the curly rest shape: shape on %.4f m, off %.4f m\n", on, off);
    assert_true(on < 0.8 * off);
}

/* Mean distance from each non-root vertex to the nearest vertex of another strand. */
static double mean_nearest_other_strand(const fixture *f)
{
    uint32_t ns = f->groom.nstrands, nv = f->groom.nverts;
    double sum = 0.0;
    size_t cnt = 0;
    for (uint32_t s = 0; s < ns; s++)
        for (uint32_t l = nv / 2; l < nv; l++) {
            const float *a = f->x + 3 * ((size_t)s * nv + l);
            double best = INFINITY;
            for (uint32_t t = 0; t < ns; t++) {
                if (t == s) continue;
                for (uint32_t m = 0; m < nv; m++) {
                    double d = simcheck_dist3(a, f->x + 3 * ((size_t)t * nv + m));
                    if (d < best) best = d;
                }
            }
            sum += best;
            cnt++;
        }
    return sum / (double)cnt;
}

static double volume_with_sph(bool sph)
{
    sim_params p;
    sim_params_default(&p);
    p.sph = sph;
    p.shape = false; /* as in the paper's figure 2b: hair-hair interaction alone gives volume */
    p.repulsion = 0.5f;
    p.sph_radius = 0.008f;
    fixture f;
    make(&f, 384, 16, &p, 2, true);
    for (int i = 0; i < 120; i++) step(&f);
    double d = mean_nearest_other_strand(&f);
    drop(&f);
    return d;
}

/* (5) SPH repulsion gives the hair volume: strands sit further apart. */
static void test_sph_volume(void **state)
{
    (void)state;
    double on = volume_with_sph(true), off = volume_with_sph(false);
    printf("mean nearest other-strand distance: sph on %.5f m, off %.5f m\n", on, off);
    assert_true(on > 1.05 * off);
}

/* Steps f n times under head motion at 3x speed. The first run (*ref NULL) keeps its final
 * positions in *ref (malloc'd, the caller frees it); every later one must match them bit for bit. */
static void shake_and_match(fixture *f, const sim_params *p, int n, float **ref)
{
    for (int i = 0; i < n; i++) {
        sim_set_motion(&f->s, simcheck_head_motion(i * p->dt, 3.0));
        step(f);
    }
    size_t bytes = sizeof(float) * 3 * (size_t)f->groom.nstrands * f->groom.nverts;
    if (!*ref) {
        *ref = malloc(bytes);
        assert_non_null(*ref);
        memcpy(*ref, f->x, bytes);
    } else {
        assert_memory_equal(*ref, f->x, bytes);
    }
}

/* (6) The same inputs give bitwise the same positions for any thread count. */
static void test_determinism(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    p.sph_radius = 0.006f;
    float *ref = NULL;
    const int threads[] = { 1, 2, 3, 5 };
    for (size_t k = 0; k < sizeof threads / sizeof threads[0]; k++) {
        fixture f;
        make(&f, 300, 12, &p, threads[k], true);
        shake_and_match(&f, &p, 40, &ref);
        drop(&f);
    }
    free(ref);
}

/* Runs style (ns x nv, p) twice on two threads for steps steps with the head in
 * simcheck_head_motion(t, speed): once as is, once with the state written back before every
 * step (which voids the SPH lists, so every pass searches). Returns the largest distance
 * between the two runs' vertices as a fraction of the mean strand length, and the first run's
 * SPH passes and searches. */
static double kept_vs_search(groom_style style, uint32_t ns, uint32_t nv, const sim_params *p, double speed, int steps,
                             sim_stats *st)
{
    fixture kept, fresh;
    make_style(&kept, style, ns, nv, p, 2, true);
    make_style(&fresh, style, ns, nv, p, 2, true);
    const size_t n = (size_t)ns * nv;
    float *vel = malloc(sizeof(float) * 3 * n);
    assert_non_null(vel);
    core_err err;
    for (int i = 0; i < steps; i++) {
        const core_xform h = simcheck_head_motion(i * p->dt, speed);
        assert_int_equal(sim_read_state(&fresh.s, fresh.x, vel, &err), CORE_OK);
        assert_int_equal(sim_write_state(&fresh.s, fresh.x, vel, &err), CORE_OK);
        sim_set_motion(&kept.s, h);
        sim_set_motion(&fresh.s, h);
        step(&kept);
        step(&fresh);
    }
    double worst = 0.0;
    for (size_t i = 0; i < n; i++) worst = simcheck_worse(worst, simcheck_dist3(kept.x + 3 * i, fresh.x + 3 * i));
    const double rel = worst / simcheck_mean_strand_length(&kept.groom);
    sim_get_stats(&kept.s, st);
    printf("kept lists vs a search every step, %d steps: max distance %.3g m = %.3g of the strand length; searched "
           "%llu of %llu passes\n",
           steps, worst, rel, (unsigned long long)st->sph_searches, (unsigned long long)st->sph_passes);
    free(vel);
    drop(&kept);
    drop(&fresh);
    return rel;
}

/* The SPH neighbour lists kept between searches (skin lists) give what a search every step
 * gives: the same run with the state written back before every step ends within rounding of
 * it. Dense (many neighbours per particle) with the head moving violently; and hair swinging
 * with a moving head at the defaults, where the lists are kept while neighbouring hair moves
 * together (most passes keep them: the relative check of sim_cpu_sph.c), which a search every
 * pass must match too. */
static void test_kept_lists_match_search(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    p.sph_radius = 0.008f;
    p.repulsion = 0.5f;
    p.global_stiffness = 300.0f; /* the hair swings fast: most passes search */
    sim_stats st;
    assert_true(kept_vs_search(GROOM_CURLY, 512, 16, &p, 3.0, 60, &st) <= 1e-5);
    sim_params_default(&p);
    assert_true(kept_vs_search(GROOM_WAVY, 2048, 32, &p, 0.5, 90, &st) <= 1e-5);
    assert_true(st.sph_searches * 4 <= st.sph_passes);
}

/* The AVX2 kernels (SPH search, density, forces) give the same bits as the portable scalar
 * ones, with lists of more than one block of 8 neighbours and with a cap that is not a
 * multiple of 8. (Without AVX2 both runs take the scalar path.) */
static void test_scalar_kernels_match(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    p.sph_radius = 0.008f; /* dense: many particles hold more than 8 neighbours */
    const int caps[] = { 24, 13 };
    for (size_t c = 0; c < 2; c++) {
        p.neighbor_cap = caps[c];
        float *ref = NULL;
        for (int scalar = 1; scalar >= 0; scalar--) { /* the scalar run first: it gives ref */
            fixture f;
            sim_desc d = { .backend = SIM_BACKEND_CPU, .threads = 2, .portable = scalar };
            make_desc(&f, GROOM_CURLY, 1024, 16, &p, &d, true);
            shake_and_match(&f, &p, 30, &ref);
            drop(&f);
        }
        free(ref);
    }
}

/* Parameters are validated: type ranges and finiteness, with the field named. */
static void test_param_validation(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    core_err err;
    assert_int_equal(sim_params_validate(&p, &err), CORE_OK);
    p.damping = NAN;
    assert_int_equal(sim_params_validate(&p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "damping"));
    sim_params_default(&p);
    p.local_stiffness = 2.0e8f;
    assert_int_equal(sim_params_validate(&p, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "local_stiffness"));
    sim_params_default(&p);
    p.substeps = 0;
    assert_int_equal(sim_params_validate(&p, &err), CORE_EINVAL);
    fixture f;
    sim_params_default(&p);
    make(&f, 16, 8, &p, 1, true);
    p.gravity = INFINITY;
    assert_int_equal(sim_set_params(&f.s, &p, &err), CORE_EINVAL);
    drop(&f);
}

/* Gravity and parameter changes take effect between steps. */
static void test_param_changes(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    p.shape = false;
    p.sph = false; /* with shape off, SPH spreads the strands even without gravity (volume) */
    fixture f;
    make(&f, 64, 12, &p, 1, false);
    core_err err;
    p.gravity = 0.0f;
    assert_int_equal(sim_set_params(&f.s, &p, &err), CORE_OK);
    for (int i = 0; i < 30; i++) step(&f);
    double still = mean_rest_distance(&f, core_xform_identity());
    p.gravity = 9.81f;
    assert_int_equal(sim_set_params(&f.s, &p, &err), CORE_OK);
    for (int i = 0; i < 30; i++) step(&f);
    double fell = mean_rest_distance(&f, core_xform_identity());
    printf("gravity off: %.5f m from rest; on: %.5f m\n", still, fell);
    assert_true(still < 1e-4);
    assert_true(fell > 0.01);
    drop(&f);
}

/* A non-finite blow-up is contained: the strand is restored and counted. */
static void test_nan_guard(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    fixture f;
    make(&f, 32, 8, &p, 2, true);
    size_t n = 3 * 32 * 8;
    float *vel = calloc(n, sizeof *vel);
    core_err err;
    assert_int_equal(sim_read_state(&f.s, f.x, vel, &err), CORE_OK);
    for (int l = 1; l < 8; l++) { /* strand 5 at the edge of float range: the prediction overflows */
        f.x[3 * (5 * 8 + l)] = 3.4e38f;
        vel[3 * (5 * 8 + l)] = 3.4e38f;
    }
    assert_int_equal(sim_write_state(&f.s, f.x, vel, &err), CORE_OK);
    step(&f);
    assert_all_finite(&f);
    sim_stats st;
    sim_get_stats(&f.s, &st);
    assert_int_equal(st.nan_resets, 1);
    vel[0] = NAN;
    assert_int_equal(sim_write_state(&f.s, f.x, vel, &err), CORE_EINVAL);
    free(vel);
    drop(&f);
}

/* Roots follow the head transform exactly. */
static void test_roots_follow_head(void **state)
{
    (void)state;
    sim_params p;
    sim_params_default(&p);
    p.substeps = 3;
    fixture f;
    make(&f, 40, 8, &p, 2, true);
    core_xform h = simcheck_head_motion(0.37, 1.0);
    sim_set_motion(&f.s, h);
    step(&f);
    for (uint32_t s = 0; s < 40; s++) {
        const float *r = f.groom.pos + 3 * (size_t)s * 8;
        core_vec3 want = core_xform_point(h, core_v3(r[0], r[1], r[2]));
        const float *got = f.x + 3 * (size_t)s * 8;
        assert_float_equal(got[0], want.x, 1e-6);
        assert_float_equal(got[1], want.y, 1e-6);
        assert_float_equal(got[2], want.z, 1e-6);
    }
    drop(&f);
}

/* SPH is evaluated at SIM_SPH_RATE in whole steps with shape on (every second step at 1/60 s,
 * every fourth at 0.008 s, every step at 1/30 s), faster past SIM_SPH_RATE_REPULSION (every
 * step at repulsion 0.5), every step with shape off; an evaluation
 * keeps exp(-elapsed / SIM_SPH_SMOOTH_TIME) of the held acceleration (none when cold), and
 * turning SPH off leaves the backend cold. */
static void test_sph_clock(void **state)
{
    (void)state;
    const struct { float dt, repulsion; bool shape; const char *pattern; } cases[] = {
        { 1.0f / 60.0f, 0.1f, true, "YnYnYnYn" }, { 0.008f, 0.1f, true, "YnnnYnnnY" },
        { 1.0f / 30.0f, 0.1f, true, "YYYY" },     { 1.0f / 60.0f, 0.1f, false, "YYYY" },
        { 1.0f / 60.0f, 0.5f, true, "YYYY" },     { 0.008f, 0.2f, true, "YnYnY" },
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        sim_params p;
        sim_params_default(&p);
        p.dt = cases[c].dt;
        p.shape = cases[c].shape;
        p.repulsion = cases[c].repulsion;
        sim_sph_clock clk = { 0 };
        for (size_t k = 0; cases[c].pattern[k]; k++) {
            sim_step_desc d = { .sph = true };
            sim_step_sph_clock(&p, &clk, &d);
            assert_int_equal(d.sph_eval, cases[c].pattern[k] == 'Y');
            const uint32_t every = cases[c].shape ? (uint32_t)(strchr(cases[c].pattern + 1, 'Y') - cases[c].pattern) : 1;
            const double keep = k == 0 || !d.sph_eval || !cases[c].shape ? 0.0 : exp(-every * (double)p.dt / SIM_SPH_SMOOTH_TIME);
            assert_float_equal(d.sph_keep, keep, 1e-6);
        }
    }
    sim_params p;
    sim_params_default(&p);
    sim_sph_clock clk = { 0 };
    sim_step_desc d = { .sph = true };
    sim_step_sph_clock(&p, &clk, &d);
    d = (sim_step_desc){ .sph = false };
    sim_step_sph_clock(&p, &clk, &d);
    assert_false(d.sph_eval);
    d = (sim_step_desc){ .sph = true };
    sim_step_sph_clock(&p, &clk, &d);
    assert_true(d.sph_eval);
    assert_float_equal(d.sph_keep, 0.0, 0.0);
}

/* sim_time_steps: the warm-up is not timed, every timed step counts, a budget stops early. */
static void test_time_steps(void **state)
{
    (void)state;
    fixture f;
    sim_params p;
    sim_params_default(&p);
    make(&f, 64, 8, &p, 1, true);
    core_err err;
    sim_timing t;
    sim_stats before, after;
    sim_get_stats(&f.s, &before);
    assert_int_equal(sim_time_steps(&f.s, f.x, 4, 0.0, &t, &err), CORE_OK);
    sim_get_stats(&f.s, &after);
    assert_int_equal(t.steps, 4);
    assert_int_equal(after.steps - before.steps, 5); /* the warm-up and the four timed */
    assert_true(t.best_s > 0.0 && t.best_s <= t.mean_s);
    assert_int_equal(sim_time_steps(&f.s, f.x, 50, 1e-9, &t, &err), CORE_OK);
    assert_int_equal(t.steps, 1); /* the budget is spent after the first timed step */
    assert_true(t.best_s > 0.0 && t.best_s <= t.mean_s);
    drop(&f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_inextensibility),   cmocka_unit_test(test_collisions),
        cmocka_unit_test(test_robustness),        cmocka_unit_test(test_shape_preservation),
        cmocka_unit_test(test_sph_volume),        cmocka_unit_test(test_determinism),
        cmocka_unit_test(test_param_validation),  cmocka_unit_test(test_param_changes),
        cmocka_unit_test(test_nan_guard),         cmocka_unit_test(test_roots_follow_head),
        cmocka_unit_test(test_scalar_kernels_match), cmocka_unit_test(test_kept_lists_match_search),
        cmocka_unit_test(test_sph_clock),
        cmocka_unit_test(test_time_steps),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
