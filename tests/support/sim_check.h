/* Test support: the scripted head motion, groom fixture and geometric checks the solver tests share. */
#ifndef TESTS_SIM_CHECK_H
#define TESTS_SIM_CHECK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "app/app_anim.h"
#include "core/groom_types.h"
#include "core/math3.h"
#include "groom/groom.h"
#include "sim/sim.h"

/* Violent scripted head motion at time t (s): swings, nods and shakes, speed times as fast as
 * the base script. Pure function; any thread. */
core_xform simcheck_head_motion(double t, double speed);

/* Makes the procedural groom style, ns strands x nv vertices from seed (0: the groom module's
 * default seed) with its default colliders into g, which the caller owns and frees with
 * core_groom_free. Fails the running cmocka test with the reason when the groom is refused. */
void simcheck_groom(core_groom *g, groom_style style, uint32_t ns, uint32_t nv, uint64_t seed);

/* Loads Ratboy's mohawk (STRANDCAST_ASSETS/ratboy/Ratboy_mohawk.tfx, its fitted head
 * ellipsoid) into g and, when sdf, its body mesh (Ratboy_body.tfxmesh) with the signed
 * distance grid built over the head region (the mesh vertices above y = 0.6 m, as test_mesh).
 * Returns false, g zeroed, when the assets are absent; fails the running test when they do
 * not load. The caller owns g (core_groom_free). */
bool simcheck_ratboy(core_groom *g, bool sdf);
/* The larger of worst and x, where a NaN on either side wins and stays: a running maximum
 * that a non-finite figure makes fail every later <= threshold check. */
double simcheck_worse(double worst, double x);

/* Distance between the points a[0..2] and b[0..2], computed in double precision. */
double simcheck_dist3(const float *a, const float *b);

/* Mean distance between the n points of a and of b (3 floats each, same order); n > 0. */
double simcheck_mean_distance(const float *a, const float *b, size_t n);

/* Mean rest length of g's strands (sum of segment lengths of g->pos / nstrands). */
double simcheck_mean_strand_length(const core_groom *g);

/* Deepest penetration of a non-root vertex of positions x (laid out as g->pos; roots are
 * kinematic, placed by the groom) into any of g's colliders moved by head transform h, as a
 * fraction of the collider's radius (for an ellipsoid, of its radius along that direction):
 * > 0 inside, <= 0 outside, -1 when g has no colliders; NaN when any figure is non-finite. */
double simcheck_deepest_penetration(const core_groom *g, core_xform h, const float *x);

/* Gives g (a procedural groom, head at the origin) a distance grid of a sphere around the head's
 * centre, 12 mm larger than the head ellipsoid's smallest semi-axis, so that the hair near the
 * scalp is pushed by it; g owns it (core_groom_free). Fails the running test when it cannot. */
void simcheck_sphere_sdf(core_groom *g);

/* Runs animation preset p for secs on g (CPU backend, 2 threads, parameters prm): the worst
 * segment-length error (quality_segment_error_max of segments of at least min_rest) and the
 * deepest penetration (metres, quality_penetration_max) over the steps' end states. Fails the
 * running test when the solver refuses. */
void simcheck_preset_errors(const core_groom *g, const sim_params *prm, app_preset p, double secs, double min_rest,
                            double *seg, double *pen);

/* The stillness bound of the rest tests: p99.9 of the per-frame displacement of the non-root
 * vertices, metres per 1/60 s. */
#define SIMCHECK_REST_P999 1e-5

/* A solver on a groom with the buffers to measure per-frame displacement. Zero it, fill groom,
 * then simcheck_run_open; simcheck_run_close frees all (the groom too). */
typedef struct simcheck_run {
    core_groom groom;
    sim s;
    float *x, *prev, *scratch;
    size_t n;
} simcheck_run;

/* Creates the CPU solver for r->groom with p and `threads` workers (fails the test otherwise). */
void simcheck_run_open(simcheck_run *r, const sim_params *p, int threads);
void simcheck_run_close(simcheck_run *r);
/* One step under head h; returns the 99.9th percentile of the non-root vertices' displacement (m). */
double simcheck_run_step(simcheck_run *r, core_xform h);
/* The rest check the parameter tests share: the wavy style, 96 x 16 (seed 11) with its colliders,
 * under p (CPU, 2 threads), 1 s of the violent script then 3 s with the head still. Returns
 * simcheck_motion_then_rest's figure (m per 1/60 s) and sets *settle. */
double simcheck_wavy_rest(const sim_params *p, double *settle);

/* Makes 64 strands of 16 vertices sticking out sideways (+x, 0.1 m, a slight upward curve) from a
 * row of roots along z into g (the caller owns it: core_groom_free): a cantilever gravity bends. */
void simcheck_cantilever(core_groom *g);

/* Releases simcheck_cantilever from its rest pose under p (CPU, 2 threads), head still, for 3 s.
 * *sag: the mean drop of the tips at the end (m). *decay: the time (s) the swing takes to decay to
 * 1/1000 of the initial drop: the mean tip height's distance from where it ends, taken at its
 * peaks (the swing's turning points) and interpolated log-linearly between the last peak above
 * that level and the first below, so the figure does not jump by half a period of the swing when
 * the damping changes a little (the last frame above a threshold does). Fails the running test
 * when the hair is not at rest (SIMCHECK_REST_P999) at the end. */
void simcheck_sag_and_decay(const sim_params *p, double *sag, double *decay);

/* Stiffness and damping are per unit of time: under p (its dt and substeps replaced),
 * simcheck_sag_and_decay's sag at (1/60 s, 4 substeps), (1/60 s, 8) and (1/30 s, 8) agrees
 * within 10% of the first's and its decay time within decay_tol (a fraction) of the first's
 * (printed; fails the running test otherwise). */
void simcheck_dt_independence(const sim_params *p, double decay_tol);

/* The head: the violent test script (simcheck_head_motion) for `moving` s, then a 0.25 s blend
 * back to the identity. */
core_xform simcheck_rest_head(double t, double moving);
/* Moves the head for `moving` s, holds it still for `still` s; returns the last frame's p99.9
 * displacement per 1/60 s and, in *settle (NULL: not asked), the time after the stop when it
 * last exceeded SIMCHECK_REST_P999 per 1/60 s. */
double simcheck_motion_then_rest(simcheck_run *r, float dt, double moving, double still, double *settle);

#endif
