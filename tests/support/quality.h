/* Test support: hair quality metrics (stillness, stretch, penetration, shape, volume) on strand positions. */
#ifndef TESTS_QUALITY_H
#define TESTS_QUALITY_H

#include <stddef.h>
#include <stdint.h>

#include "core/core.h"
#include "core/groom_types.h"
#include "core/math3.h"

/* Every function below reads positions laid out as a groom's: strand-major xyz, vertex v of
 * strand s at x[3 * (s * nverts + v)], vertex 0 the root. Units are the groom's (metres).
 * None keeps state or allocates unless it says so; all are pure and callable from any thread
 * on inputs no other thread writes. A non-finite position makes a figure NaN, never a crash. */

/* The q-quantile (0 <= q <= 1, nearest rank: the ceil(q * m)-th smallest, the smallest when
 * that is 0) of |cur - prev| over the m = nstrands * (nverts - 1) non-root vertices: the
 * per-frame displacement of the hair between two frames. scratch holds at least m doubles
 * (caller-owned, overwritten). Returns 0 when m is 0, NaN when any displacement is NaN. */
double quality_displacement_quantile(const float *cur, const float *prev, uint32_t nstrands, uint32_t nverts,
                                     double q, double *scratch);

/* Largest |len / rest_len - 1| over the segments of x whose rest length (taken from g->pos; x
 * has g's layout) is above zero and at least min_rest metres (shorter ones, such as Ratboy's
 * 7.5 um strand, have float32 rounding for a ratio). 0 for a groom at rest; NaN when any
 * position is non-finite. Pure. */
double quality_segment_error_max(const core_groom *g, const float *x, double min_rest);
/* Mean |len - rest_len| / rest_len over every segment of x (rest lengths from g->pos, all above
 * zero; x has g's layout). Pure. */
double quality_segment_error_mean(const core_groom *g, const float *x);

/* How deep the point p (world space) is inside collider c moved rigidly by head transform h,
 * in metres: > 0 inside, <= 0 outside (the negated distance to the surface for spheres and
 * capsules). Ellipsoids: the depth along the radial direction, computed in the unit-sphere
 * coordinates of the ellipsoid and scaled back, |u| (1 - |s|) / |s| with u the point in the
 * ellipsoid frame and s = u / radii (exact on a sphere; at the centre, the smallest
 * semi-axis). */
double quality_collider_depth(const core_collider *c, core_xform h, core_vec3 p);

/* Deepest penetration, in metres, of any non-root vertex of x (g's layout; roots are
 * kinematic, placed by the groom) into the character of g moved by h: every collider
 * (quality_collider_depth) and, where the groom gets other collision shapes (a mesh SDF),
 * their depth term in the same per-vertex function. The groom is authored in contact with its
 * mesh: a vertex whose rest position (g->pos) lies d inside the mesh's distance grid counts
 * only beyond that depth (the solvers hold it there, sim_groom_contact_floor). 0 when nothing
 * is inside or g has no colliders; NaN when any position is non-finite. */
double quality_penetration_max(const core_groom *g, core_xform h, const float *x);

/* Mean rest length of g's strands (sum of the segment lengths of g->pos / nstrands), metres.
 * 0 for a groom without strands. */
double quality_mean_strand_length(const core_groom *g);

/* Mean over the non-root vertices of |x - h(rest)|, where rest is g->pos (the authored
 * groom in the head frame) moved by head transform h, divided by the groom's mean strand
 * length (quality_mean_strand_length): 0 when the hair holds its authored shape exactly.
 * NaN when any position is non-finite or the strands have zero length. */
double quality_shape_deviation(const core_groom *g, core_xform h, const float *x);

/* Fraction (0..1) of the nstrands strands of x whose tip (last vertex) is higher in y (world
 * up) than their root. 0 when nstrands is 0; a NaN tip or root counts as not above. */
double quality_tips_above_roots(const float *x, uint32_t nstrands, uint32_t nverts);

/* Mean over all nstrands * nverts vertices of x of the distance to the nearest vertex of
 * another strand (hair volume: how far apart the strands are), in *out. Uses a uniform grid
 * hash (cell = the mean segment length of x, counting sort by hashed cell, rings of cells
 * searched outward until no nearer point can remain): about linear in the vertex count.
 * Allocates temporary memory (freed before returning). *out = NaN when any position is
 * non-finite. CORE_EINVAL when nstrands < 2 or nverts < 1, CORE_ENOMEM when memory runs out
 * (err says which). */
core_status quality_nn_other_strand_mean(const float *x, uint32_t nstrands, uint32_t nverts, double *out,
                                         core_err *err);

#endif
