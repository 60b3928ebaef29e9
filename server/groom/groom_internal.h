/* groom: helpers shared inside the groom module (collider geometry, PRNG); not public. */
#ifndef GROOM_INTERNAL_H
#define GROOM_INTERNAL_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "../core/core.h"
#include "../core/groom_types.h"
#include "../core/math3.h"

/* Moves p out of collider c so it lies at least margin outside (radially for ellipsoids).
 * Returns 1 when p was moved, 0 when it was already outside by margin. Pure. */
int groom_collider_push_out(const core_collider *c, core_vec3 *p, float margin);

/* 1 when p is strictly inside c (no margin). Pure. */
int groom_collider_contains(const core_collider *c, core_vec3 p);

/* Outward direction of c at a point p outside or on it (unit; +y when undefined). Pure. */
core_vec3 groom_collider_outward(const core_collider *c, core_vec3 p);

/* Little-endian reads from a byte buffer; the caller has checked off + 4 <= size. */
static inline uint32_t groom_rd_u32(const unsigned char *b, size_t off)
{
    return (uint32_t)b[off] | (uint32_t)b[off + 1] << 8 | (uint32_t)b[off + 2] << 16 | (uint32_t)b[off + 3] << 24;
}
static inline float groom_rd_f32(const unsigned char *b, size_t off)
{
    uint32_t u = groom_rd_u32(b, off);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* Reads strand `strand`'s n_in points (3 floats each, stride bytes apart, starting at byte
 * `off` of data; the caller has checked they are in bounds) into tmp[3 * n_in], refuses
 * non-finite values and zero length (CORE_EFORMAT naming the strand, vertex and byte offset,
 * prefixed by `what`), and resamples them into out[3 * n_out]. */
core_status groom_take_strand(const unsigned char *data, size_t off, size_t stride, uint32_t n_in, float *tmp,
                              float *out, uint32_t n_out, uint32_t strand, const char *what, core_err *err);

/* 1 when path ends in ext (case-insensitive) after at least one other character. Pure. */
int groom_has_ext(const char *path, const char *ext);

/* Reads the whole file at path into a malloc'd buffer (*data, *size; the caller frees it);
 * refuses files over max_bytes (CORE_EINVAL). what names the file in messages ("groom file").
 * Blocking I/O, any thread. */
core_status groom_read_all(const char *path, size_t max_bytes, const char *what, unsigned char **data, size_t *size,
                           core_err *err);

/* Winding number of the closed mesh m around every sample of the grid g (dims, origin and
 * cell used; g->d untouched), written to wind[dims[0]*dims[1]*dims[2]] (x fastest): counted
 * along +x grid lines from the crossings of each line with the triangles in front of the
 * sample, with a consistent tie-break (a symbolic perturbation of the line) so that a line
 * through an edge or vertex counts it exactly once. Nonzero = inside. m must have passed
 * groom_mesh_check. Pure, any thread. */
void groom_sdf_winding(const core_mesh *m, const core_sdf *g, int16_t *wind);

/* splitmix64 generator: the state is the caller's. */
typedef struct groom_rng { uint64_t s; } groom_rng;

static inline uint64_t groom_rng_next(groom_rng *r)
{
    uint64_t z = (r->s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* Uniform float in [0, 1). */
static inline float groom_rng_float(groom_rng *r) { return (float)(groom_rng_next(r) >> 40) * (1.0f / 16777216.0f); }

#endif
