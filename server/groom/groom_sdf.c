/* groom: signed distance grid of a closed mesh (exact near band, propagated far field, winding sign). */
#include "groom.h"
#include "groom_internal.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>

#define BAND_CELLS 3.0f       /* exact distances at least this far from the surface */
#define MIN_CELLS 4096u       /* a max_cells below this is raised to it */
#define UNSEEN 1e10f          /* closest-point placeholder of samples not reached yet */
#define BRUTE_BUDGET (1u << 26) /* sample x triangle tests when no triangle is near the grid */

static inline core_vec3 vtx(const core_mesh *m, uint32_t i)
{
    return core_v3(m->pos[3 * (size_t)i], m->pos[3 * (size_t)i + 1], m->pos[3 * (size_t)i + 2]);
}

/* Closest point to p on triangle abc (Ericson, Real-Time Collision Detection, 5.1.5). */
static core_vec3 closest_on_tri(core_vec3 p, core_vec3 a, core_vec3 b, core_vec3 c)
{
    core_vec3 ab = core_v3_sub(b, a), ac = core_v3_sub(c, a), ap = core_v3_sub(p, a);
    float d1 = core_v3_dot(ab, ap), d2 = core_v3_dot(ac, ap);
    if (d1 <= 0.0f && d2 <= 0.0f) return a;
    core_vec3 bp = core_v3_sub(p, b);
    float d3 = core_v3_dot(ab, bp), d4 = core_v3_dot(ac, bp);
    if (d3 >= 0.0f && d4 <= d3) return b;
    float vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f) return core_v3_add(a, core_v3_scale(ab, d1 / (d1 - d3)));
    core_vec3 cp = core_v3_sub(p, c);
    float d5 = core_v3_dot(ab, cp), d6 = core_v3_dot(ac, cp);
    if (d6 >= 0.0f && d5 <= d6) return c;
    float vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f) return core_v3_add(a, core_v3_scale(ac, d2 / (d2 - d6)));
    float va = d3 * d6 - d5 * d4;
    if (va <= 0.0f && (d4 - d3) >= 0.0f && (d5 - d6) >= 0.0f)
        return core_v3_add(b, core_v3_scale(core_v3_sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6))));
    float den = 1.0f / (va + vb + vc);
    return core_v3_add(a, core_v3_add(core_v3_scale(ab, vb * den), core_v3_scale(ac, vc * den)));
}

static inline core_vec3 sample_pos(const core_sdf *g, uint32_t i, uint32_t j, uint32_t k)
{
    return core_v3(g->origin.x + (float)i * g->cell, g->origin.y + (float)j * g->cell, g->origin.z + (float)k * g->cell);
}

/* Chooses cell, origin and dims for the region of d (see groom_sdf_desc). */
static core_status plan(const core_mesh *m, const groom_sdf_desc *d, core_sdf *g, core_err *err)
{
    float cell = d->cell != 0.0f ? d->cell : GROOM_SDF_DEFAULT_CELL;
    if (!isfinite(cell) || !(cell > 0.0f) || cell > 1000.0f)
        return core_fail(err, CORE_EINVAL, "distance grid cell %g m is not in (0, 1000]", (double)d->cell);
    double max_cells = d->max_cells ? d->max_cells : GROOM_SDF_DEFAULT_MAX_CELLS;
    if (max_cells < MIN_CELLS) max_cells = MIN_CELLS;
    core_vec3 lo = d->lo, hi = d->hi;
    double margin = 2.0;
    if (lo.x == 0.0f && lo.y == 0.0f && lo.z == 0.0f && hi.x == 0.0f && hi.y == 0.0f && hi.z == 0.0f) {
        margin = 4.0;
        lo = hi = vtx(m, 0);
        for (uint32_t v = 1; v < m->nverts; v++) {
            core_vec3 p = vtx(m, v);
            lo = core_v3(fminf(lo.x, p.x), fminf(lo.y, p.y), fminf(lo.z, p.z));
            hi = core_v3(fmaxf(hi.x, p.x), fmaxf(hi.y, p.y), fmaxf(hi.z, p.z));
        }
    } else {
        float c[6] = { lo.x, lo.y, lo.z, hi.x, hi.y, hi.z };
        for (int i = 0; i < 6; i++)
            if (!isfinite(c[i]) || fabsf(c[i]) > 1000.0f)
                return core_fail(err, CORE_EINVAL, "distance grid region coordinate %g is not finite or beyond 1000 m",
                                 (double)c[i]);
        if (!(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z))
            return core_fail(err, CORE_EINVAL, "distance grid region [%g %g %g] - [%g %g %g] is empty", (double)lo.x,
                             (double)lo.y, (double)lo.z, (double)hi.x, (double)hi.y, (double)hi.z);
    }
    double ext[3] = { (double)hi.x - lo.x, (double)hi.y - lo.y, (double)hi.z - lo.z }, n[3], total = 0.0;
    for (int it = 0; it < 10000; it++) {
        total = 1.0;
        for (int a = 0; a < 3; a++) {
            n[a] = ceil(ext[a] / cell + 2.0 * margin) + 1.0;
            total *= n[a];
        }
        if (total <= max_cells) break;
        double grow = cbrt(total / max_cells);
        cell *= (float)(grow > 1.001 ? grow : 1.001);
    }
    if (total > max_cells) /* cannot happen: (2 margin + 2)^3 <= MIN_CELLS */
        return core_fail(err, CORE_EINVAL, "distance grid does not fit in %.0f samples", max_cells);
    for (int a = 0; a < 3; a++) g->dims[a] = (uint32_t)n[a];
    g->cell = cell;
    g->origin = core_v3(lo.x - (float)margin * cell, lo.y - (float)margin * cell, lo.z - (float)margin * cell);
    return CORE_OK;
}

/* Index range of samples within [lo, hi] along one axis, clamped; 0 when none. The caller's
 * band has slack for the rounding of the sample positions. */
static int span(float lo, float hi, float o, float cell, uint32_t n, uint32_t *a, uint32_t *b)
{
    float fa = floorf((lo - o) / cell), fb = ceilf((hi - o) / cell);
    if (fb < 0.0f || fa > (float)(n - 1) || !(fa <= fb)) return 0;
    *a = (uint32_t)fmaxf(fa, 0.0f);
    *b = (uint32_t)fminf(fb, (float)(n - 1));
    return 1;
}

/* Exact squared distances and closest points for the samples within the band of each
 * triangle. Returns the number of samples reached. */
static size_t band_pass(const core_mesh *m, const core_sdf *g, float *d2, float *cp)
{
    float band = BAND_CELLS * g->cell * 1.001f;
    uint32_t nx = g->dims[0], ny = g->dims[1];
    size_t seeded = 0;
    for (uint32_t t = 0; t < m->ntris; t++) {
        const uint32_t *v = m->tri + 3 * (size_t)t;
        core_vec3 a = vtx(m, v[0]), b = vtx(m, v[1]), c = vtx(m, v[2]);
        uint32_t i0, i1, j0, j1, k0, k1;
        if (!span(fminf(a.x, fminf(b.x, c.x)) - band, fmaxf(a.x, fmaxf(b.x, c.x)) + band, g->origin.x, g->cell, nx,
                  &i0, &i1) ||
            !span(fminf(a.y, fminf(b.y, c.y)) - band, fmaxf(a.y, fmaxf(b.y, c.y)) + band, g->origin.y, g->cell, ny,
                  &j0, &j1) ||
            !span(fminf(a.z, fminf(b.z, c.z)) - band, fmaxf(a.z, fmaxf(b.z, c.z)) + band, g->origin.z, g->cell,
                  g->dims[2], &k0, &k1))
            continue;
        core_vec3 nrm = core_v3_norm(core_v3_cross(core_v3_sub(b, a), core_v3_sub(c, a)));
        float hx = nrm.x * g->cell;
        for (uint32_t k = k0; k <= k1; k++)
            for (uint32_t j = j0; j <= j1; j++) {
                /* signed height over the plane is h0 + hx * i: keep the i with |h| <= band */
                uint32_t r0 = i0, r1 = i1;
                float h0 = core_v3_dot(nrm, core_v3_sub(sample_pos(g, 0, j, k), a));
                if (fabsf(hx) > 1e-6f * g->cell) {
                    float ua = (-band - h0) / hx, ub = (band - h0) / hx;
                    if (!span(fminf(ua, ub) * g->cell - 1.0f * g->cell, fmaxf(ua, ub) * g->cell + 1.0f * g->cell, 0.0f,
                              g->cell, nx, &r0, &r1))
                        continue;
                    r0 = r0 > i0 ? r0 : i0;
                    r1 = r1 < i1 ? r1 : i1;
                } else if (fabsf(h0) > band) continue;
                size_t row = ((size_t)k * ny + j) * nx;
                for (uint32_t i = r0; i <= r1; i++) {
                    core_vec3 p = sample_pos(g, i, j, k);
                    core_vec3 q = closest_on_tri(p, a, b, c);
                    core_vec3 e = core_v3_sub(p, q);
                    float dd = core_v3_dot(e, e);
                    size_t at = row + i;
                    if (dd < d2[at]) {
                        seeded += d2[at] == FLT_MAX;
                        d2[at] = dd;
                        cp[3 * at] = q.x;
                        cp[3 * at + 1] = q.y;
                        cp[3 * at + 2] = q.z;
                    }
                }
            }
    }
    return seeded;
}

/* No triangle comes near the grid: exact closest points on a sub-lattice (every s-th sample),
 * which the sweeps then spread. */
static void brute_seed(const core_mesh *m, const core_sdf *g, float *d2, float *cp)
{
    uint32_t s = 1;
    for (;;) {
        double pts = 1.0;
        for (int a = 0; a < 3; a++) pts *= (double)((g->dims[a] + s - 1) / s);
        if (pts * m->ntris <= BRUTE_BUDGET || s >= 1u << 16) break;
        s *= 2;
    }
    for (uint32_t k = 0; k < g->dims[2]; k += s)
        for (uint32_t j = 0; j < g->dims[1]; j += s)
            for (uint32_t i = 0; i < g->dims[0]; i += s) {
                core_vec3 p = sample_pos(g, i, j, k);
                size_t at = ((size_t)k * g->dims[1] + j) * g->dims[0] + i;
                for (uint32_t t = 0; t < m->ntris; t++) {
                    const uint32_t *v = m->tri + 3 * (size_t)t;
                    core_vec3 q = closest_on_tri(p, vtx(m, v[0]), vtx(m, v[1]), vtx(m, v[2]));
                    core_vec3 e = core_v3_sub(p, q);
                    float dd = core_v3_dot(e, e);
                    if (dd < d2[at]) {
                        d2[at] = dd;
                        cp[3 * at] = q.x;
                        cp[3 * at + 1] = q.y;
                        cp[3 * at + 2] = q.z;
                    }
                }
            }
}

/* Takes the closest point q of a neighbour when it is nearer to p than the best so far
 * (branch-free selects). */
static inline void take(float px, float py, float pz, const float *q, float *best, float *bx, float *by, float *bz)
{
    float ex = px - q[0], ey = py - q[1], ez = pz - q[2];
    float dd = ex * ex + ey * ey + ez * ez;
    int t = dd < *best;
    *best = t ? dd : *best;
    *bx = t ? q[0] : *bx;
    *by = t ? q[1] : *by;
    *bz = t ? q[2] : *bz;
}

/* One raster sweep in direction (sx, sy, sz) (each +1 or -1): every sample takes the closest
 * point of its upstream neighbours when that is nearer than its own. Samples within the band
 * (exact already) are only read. */
static void sweep(const core_sdf *g, float *d2, float *cp, float band2, int sx, int sy, int sz)
{
    uint32_t nx = g->dims[0], ny = g->dims[1], nz = g->dims[2];
    for (uint32_t kk = 0; kk < nz; kk++) {
        uint32_t k = sz > 0 ? kk : nz - 1 - kk;
        for (uint32_t jj = 0; jj < ny; jj++) {
            uint32_t j = sy > 0 ? jj : ny - 1 - jj;
            float py = g->origin.y + (float)j * g->cell, pz = g->origin.z + (float)k * g->cell;
            size_t row = ((size_t)k * ny + j) * nx;
            /* upstream rows along y and z (the row itself at the first one: a no-op candidate) */
            size_t rowy = jj > 0 ? row - (ptrdiff_t)sy * nx : row;
            size_t rowz = kk > 0 ? row - (ptrdiff_t)sz * nx * ny : row;
            for (uint32_t ii = 0; ii < nx; ii++) {
                uint32_t i = sx > 0 ? ii : nx - 1 - ii;
                uint32_t ix = ii > 0 ? i - (uint32_t)sx : i;
                size_t at = row + i;
                float best = d2[at];
                if (best <= band2) continue;
                float px = g->origin.x + (float)i * g->cell;
                float bx = cp[3 * at], by = cp[3 * at + 1], bz = cp[3 * at + 2];
                take(px, py, pz, cp + 3 * (row + ix), &best, &bx, &by, &bz);
                take(px, py, pz, cp + 3 * (rowy + i), &best, &bx, &by, &bz);
                take(px, py, pz, cp + 3 * (rowz + i), &best, &bx, &by, &bz);
                d2[at] = best;
                cp[3 * at] = bx;
                cp[3 * at + 1] = by;
                cp[3 * at + 2] = bz;
            }
        }
    }
}

core_status groom_sdf_build(const core_mesh *m, const groom_sdf_desc *d, core_sdf *out, core_err *err)
{
    static const groom_sdf_desc defaults;
    memset(out, 0, sizeof *out);
    core_status st = groom_mesh_check(m, err);
    if (st != CORE_OK) return st;
    core_sdf g;
    memset(&g, 0, sizeof g);
    if ((st = plan(m, d ? d : &defaults, &g, err)) != CORE_OK) return st;
    if ((st = core_sdf_alloc(out, g.dims, g.origin, g.cell, err)) != CORE_OK) return st;
    size_t n = (size_t)g.dims[0] * g.dims[1] * g.dims[2];
    int16_t *wind = malloc(n * sizeof *wind);
    float *cp = malloc(n * 3 * sizeof *cp);
    if (!wind || !cp) {
        free(wind);
        free(cp);
        core_sdf_free(out);
        return core_fail(err, CORE_ENOMEM, "out of memory for a distance grid of %u x %u x %u samples", g.dims[0],
                         g.dims[1], g.dims[2]);
    }
    groom_sdf_winding(m, out, wind);
    float *d2 = out->d;
    for (size_t i = 0; i < n; i++) {
        d2[i] = FLT_MAX;
        cp[3 * i] = cp[3 * i + 1] = cp[3 * i + 2] = UNSEEN;
    }
    if (band_pass(m, out, d2, cp) == 0) brute_seed(m, out, d2, cp);
    float band2 = BAND_CELLS * out->cell * BAND_CELLS * out->cell;
    for (int s = 0; s < 8; s++) sweep(out, d2, cp, band2, s & 1 ? -1 : 1, s & 2 ? -1 : 1, s & 4 ? -1 : 1);
    for (size_t i = 0; i < n; i++) {
        float dist = sqrtf(d2[i]);
        d2[i] = wind[i] != 0 ? -dist : dist;
    }
    free(wind);
    free(cp);
    return CORE_OK;
}

bool groom_collider_region(const core_groom *g, const core_mesh *m, core_vec3 *lo, core_vec3 *hi)
{
    float rlo[3] = { FLT_MAX, FLT_MAX, FLT_MAX }, rhi[3] = { -FLT_MAX, -FLT_MAX, -FLT_MAX };
    double longest = 0.0;
    bool any = false;
    for (size_t s = 0; s < g->nstrands; s++) {
        const float *p = g->pos + 3 * s * g->nverts;
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) continue;
        any = true;
        for (int k = 0; k < 3; k++) {
            rlo[k] = fminf(rlo[k], p[k]);
            rhi[k] = fmaxf(rhi[k], p[k]);
        }
        double len = 0.0;
        for (size_t v = 1; v < g->nverts; v++) {
            const float *a = p + 3 * (v - 1), *b = p + 3 * v;
            double d = sqrt((double)(b[0] - a[0]) * (b[0] - a[0]) + (double)(b[1] - a[1]) * (b[1] - a[1]) +
                            (double)(b[2] - a[2]) * (b[2] - a[2]));
            if (isfinite(d)) len += d;
        }
        if (len > longest) longest = len;
    }
    if (!any || !m->nverts) return false;
    float mlo[3] = { FLT_MAX, FLT_MAX, FLT_MAX }, mhi[3] = { -FLT_MAX, -FLT_MAX, -FLT_MAX };
    for (size_t i = 0; i < m->nverts; i++)
        for (int k = 0; k < 3; k++) {
            mlo[k] = fminf(mlo[k], m->pos[3 * i + k]);
            mhi[k] = fmaxf(mhi[k], m->pos[3 * i + k]);
        }
    float reach = (float)longest + GROOM_COLLIDER_REACH_PAD, out_lo[3], out_hi[3];
    for (int k = 0; k < 3; k++) {
        out_lo[k] = fmaxf(rlo[k] - reach, mlo[k] - GROOM_COLLIDER_MESH_PAD);
        out_hi[k] = fminf(rhi[k] + reach, mhi[k] + GROOM_COLLIDER_MESH_PAD);
        if (!(out_lo[k] < out_hi[k])) return false;
    }
    *lo = core_v3(out_lo[0], out_lo[1], out_lo[2]);
    *hi = core_v3(out_hi[0], out_hi[1], out_hi[2]);
    return true;
}
