/* core: allocation, copies and trilinear sampling of core_mesh and core_sdf. */
#include "sdf.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

core_status core_mesh_alloc(core_mesh *m, uint32_t nverts, uint32_t ntris, core_err *err)
{
    memset(m, 0, sizeof *m);
    if (nverts) m->pos = calloc((size_t)nverts * 3, sizeof *m->pos);
    if (ntris) m->tri = calloc((size_t)ntris * 3, sizeof *m->tri);
    if ((nverts && !m->pos) || (ntris && !m->tri)) {
        core_mesh_free(m);
        return core_fail(err, CORE_ENOMEM, "out of memory for a mesh of %u vertices and %u triangles", nverts, ntris);
    }
    m->nverts = nverts;
    m->ntris = ntris;
    return CORE_OK;
}

void core_mesh_free(core_mesh *m)
{
    free(m->pos);
    free(m->tri);
    memset(m, 0, sizeof *m);
}

core_status core_mesh_copy(core_mesh *dst, const core_mesh *src, core_err *err)
{
    core_status st = core_mesh_alloc(dst, src->nverts, src->ntris, err);
    if (st != CORE_OK) return st;
    if (src->nverts) memcpy(dst->pos, src->pos, (size_t)src->nverts * 3 * sizeof *dst->pos);
    if (src->ntris) memcpy(dst->tri, src->tri, (size_t)src->ntris * 3 * sizeof *dst->tri);
    return CORE_OK;
}

core_status core_sdf_alloc(core_sdf *s, const uint32_t dims[3], core_vec3 origin, float cell, core_err *err)
{
    memset(s, 0, sizeof *s);
    if (dims[0] < 2 || dims[1] < 2 || dims[2] < 2)
        return core_fail(err, CORE_EINVAL, "distance grid needs at least 2 samples per axis (got %u x %u x %u)", dims[0],
                         dims[1], dims[2]);
    if (!isfinite(cell) || !(cell > 0.0f) || !isfinite(origin.x) || !isfinite(origin.y) || !isfinite(origin.z))
        return core_fail(err, CORE_EINVAL, "distance grid cell %g or origin is not finite and positive", (double)cell);
    size_t n, bytes;
    if (!core_mul_size(dims[0], dims[1], &n) || !core_mul_size(n, dims[2], &n) ||
        !core_mul_size(n, sizeof(float), &bytes))
        return core_fail(err, CORE_ENOMEM, "distance grid of %u x %u x %u samples is too large", dims[0], dims[1],
                         dims[2]);
    s->d = calloc(1, bytes);
    if (!s->d) return core_fail(err, CORE_ENOMEM, "out of memory for %zu distance samples", n);
    memcpy(s->dims, dims, sizeof s->dims);
    s->origin = origin;
    s->cell = cell;
    return CORE_OK;
}

void core_sdf_free(core_sdf *s)
{
    free(s->d);
    memset(s, 0, sizeof *s);
}

core_status core_sdf_copy(core_sdf *dst, const core_sdf *src, core_err *err)
{
    core_status st = core_sdf_alloc(dst, src->dims, src->origin, src->cell, err);
    if (st != CORE_OK) return st;
    memcpy(dst->d, src->d, (size_t)src->dims[0] * src->dims[1] * src->dims[2] * sizeof *dst->d);
    return CORE_OK;
}

/* One axis: clamps p to [lo, lo + (n-1) cell], returns the cell index i in [0, n-2] and the
 * fraction f in [0, 1] of the clamped point, and the offset from the box to p in *out. */
static inline uint32_t axis(float p, float lo, uint32_t n, float cell, float *f, float *out, float *q)
{
    float hi = lo + (float)(n - 1) * cell;
    float c = fminf(fmaxf(p, lo), hi); /* fmaxf(NaN, lo) = lo: c is always finite */
    float u = (c - lo) / cell;
    float fl = fminf(floorf(u), (float)(n - 2));
    *f = u - fl;
    *out = p - c;
    *q = c;
    return (uint32_t)fl;
}

float core_sdf_sample(const core_sdf *s, core_vec3 p, core_vec3 *grad)
{
    float fx, fy, fz, ox, oy, oz, qx, qy, qz;
    uint32_t i = axis(p.x, s->origin.x, s->dims[0], s->cell, &fx, &ox, &qx);
    uint32_t j = axis(p.y, s->origin.y, s->dims[1], s->cell, &fy, &oy, &qy);
    uint32_t k = axis(p.z, s->origin.z, s->dims[2], s->cell, &fz, &oz, &qz);
    size_t sx = 1, sy = s->dims[0], sz = (size_t)s->dims[0] * s->dims[1];
    const float *c = s->d + i + j * sy + k * sz;
    float d000 = c[0], d100 = c[sx], d010 = c[sy], d110 = c[sx + sy];
    float d001 = c[sz], d101 = c[sx + sz], d011 = c[sy + sz], d111 = c[sx + sy + sz];
    /* along x, then y, then z */
    float e00 = d000 + (d100 - d000) * fx, e10 = d010 + (d110 - d010) * fx;
    float e01 = d001 + (d101 - d001) * fx, e11 = d011 + (d111 - d011) * fx;
    float g0 = e00 + (e10 - e00) * fy, g1 = e01 + (e11 - e01) * fy;
    float inside = g0 + (g1 - g0) * fz;
    float outside = sqrtf(ox * ox + oy * oy + oz * oz);
    if (grad) {
        float gx0 = (d100 - d000) + ((d110 - d010) - (d100 - d000)) * fy;
        float gx1 = (d101 - d001) + ((d111 - d011) - (d101 - d001)) * fy;
        float gx = (gx0 + (gx1 - gx0) * fz) / s->cell;
        float gy = ((e10 - e00) + ((e11 - e01) - (e10 - e00)) * fz) / s->cell;
        float gz = (g1 - g0) / s->cell;
        float inv = 1.0f / fmaxf(outside, 1e-30f);
        grad->x = qx == p.x ? gx : ox * inv;
        grad->y = qy == p.y ? gy : oy * inv;
        grad->z = qz == p.z ? gz : oz * inv;
    }
    return inside + outside;
}
