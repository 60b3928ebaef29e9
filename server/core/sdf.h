/* core: triangle meshes and signed distance grids (character collision shapes) shared by
 * the groom loaders and the solvers. */
#ifndef CORE_SDF_H
#define CORE_SDF_H

#include <stdint.h>

#include "core.h"
#include "math3.h"

/* A triangle mesh in the head frame (metres). Owns pos and tri (core_mesh_free). */
typedef struct core_mesh {
    uint32_t nverts, ntris;
    float *pos;    /* 3 * nverts */
    uint32_t *tri; /* 3 * ntris, counter-clockwise seen from outside */
} core_mesh;

/* Signed distance samples on a regular grid in the head frame. Owns d (core_sdf_free). */
typedef struct core_sdf {
    uint32_t dims[3]; /* samples per axis, each >= 2 */
    core_vec3 origin; /* position of sample (0,0,0) */
    float cell;       /* sample spacing, m */
    float *d;         /* dims[0]*dims[1]*dims[2] distances, x fastest then y then z; < 0 inside */
} core_sdf;

/* Allocates a zeroed mesh of nverts vertices and ntris triangles (either may be 0; the arrays
 * are then NULL). m is overwritten; the caller owns the result (core_mesh_free). Any thread. */
core_status core_mesh_alloc(core_mesh *m, uint32_t nverts, uint32_t ntris, core_err *err);

/* Frees m's arrays and zeroes it; safe on a zeroed or already freed mesh. Any thread. */
void core_mesh_free(core_mesh *m);

/* Deep copy of src into dst (dst is overwritten, not freed; on failure it is left zeroed).
 * The caller owns dst. Any thread. */
core_status core_mesh_copy(core_mesh *dst, const core_mesh *src, core_err *err);

/* Allocates s with the given dims (each >= 2, product overflow-checked), origin and cell
 * (finite, > 0); the distances are zeroed. s is overwritten; the caller owns the result
 * (core_sdf_free). Any thread. */
core_status core_sdf_alloc(core_sdf *s, const uint32_t dims[3], core_vec3 origin, float cell, core_err *err);

/* Frees s->d and zeroes s; safe on a zeroed or already freed grid. Any thread. */
void core_sdf_free(core_sdf *s);

/* Deep copy of src into dst (dst is overwritten, not freed; on failure it is left zeroed).
 * The caller owns dst. Any thread. */
core_status core_sdf_copy(core_sdf *dst, const core_sdf *src, core_err *err);

/* Signed distance at p: trilinear interpolation of the samples, and in *grad (if non-NULL)
 * the exact gradient of that trilinear interpolant (not normalised). Outside the grid box p is
 * clamped to the box, sampled there, and the distance from p to the box is added; the
 * gradient then has, along each clamped axis, the unit direction from the box to p (pointing
 * away from the box) and along the other axes the interpolant's gradient. A NaN coordinate
 * reads as clamped to the box and gives NaN. s must be a valid grid (dims >= 2, d set).
 * Plain float arithmetic, mirrored by the shader. Pure, any thread. */
float core_sdf_sample(const core_sdf *s, core_vec3 p, core_vec3 *grad);

#endif
