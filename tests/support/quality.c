/* Test support: hair quality metrics (stillness, stretch, penetration, shape, volume) on strand positions. */
#include "quality.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>

static double dist3(const float *a, const float *b)
{
    double dx = (double)a[0] - b[0], dy = (double)a[1] - b[1], dz = (double)a[2] - b[2];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

/* The larger of worst and x, where a NaN on either side wins and stays. */
static double worse(double worst, double x)
{
    if (isnan(worst) || isnan(x)) return NAN;
    return x > worst ? x : worst;
}

static void swapd(double *a, double *b)
{
    double t = *a;
    *a = *b;
    *b = t;
}

/* The k-th smallest (0-based, k < n) of v[0..n), reordering v: quickselect with a
 * three-way partition (many equal values, e.g. still vertices, stay linear). */
static double select_kth(double *v, size_t n, size_t k)
{
    size_t lo = 0, hi = n; /* the answer is in v[lo, hi) */
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        double a = v[lo], b = v[mid], c = v[hi - 1];
        double pivot = a < b ? (b < c ? b : (a < c ? c : a)) : (a < c ? a : (b < c ? c : b));
        size_t lt = lo, i = lo, gt = hi; /* [lo,lt) < pivot, [lt,i) == pivot, [gt,hi) > pivot */
        while (i < gt) {
            if (v[i] < pivot) swapd(&v[lt++], &v[i++]);
            else if (v[i] > pivot) swapd(&v[i], &v[--gt]);
            else i++;
        }
        if (k < lt) hi = lt;
        else if (k >= gt) lo = gt;
        else return pivot;
    }
    return v[k];
}

double quality_displacement_quantile(const float *cur, const float *prev, uint32_t nstrands, uint32_t nverts,
                                     double q, double *scratch)
{
    if (nverts < 2 || nstrands == 0) return 0.0;
    size_t m = 0;
    for (uint32_t s = 0; s < nstrands; s++)
        for (uint32_t v = 1; v < nverts; v++) {
            size_t i = 3 * ((size_t)s * nverts + v);
            double d = dist3(cur + i, prev + i);
            if (isnan(d)) return NAN;
            scratch[m++] = d;
        }
    double r = ceil(q * (double)m - 1e-9); /* nearest rank, robust to q * m rounding up */
    size_t k = r < 1.0 ? 0 : r > (double)m ? m - 1 : (size_t)r - 1;
    return select_kth(scratch, m, k);
}

double quality_segment_error_max(const core_groom *g, const float *x, double min_rest)
{
    double worst = 0.0;
    for (uint32_t s = 0; s < g->nstrands; s++)
        for (uint32_t l = 1; l < g->nverts; l++) {
            size_t i = 3 * ((size_t)s * g->nverts + l);
            double rest = dist3(g->pos + i, g->pos + i - 3);
            if (!(rest > 0.0) || rest < min_rest) continue; /* no meaningful ratio */
            worst = worse(worst, fabs(dist3(x + i, x + i - 3) / rest - 1.0));
        }
    return worst;
}

double quality_segment_error_mean(const core_groom *g, const float *x)
{
    double sum = 0.0;
    size_t m = 0;
    for (uint32_t s = 0; s < g->nstrands; s++)
        for (uint32_t l = 1; l < g->nverts; l++) {
            const size_t i = 3 * ((size_t)s * g->nverts + l);
            const double rest = dist3(g->pos + i, g->pos + i - 3);
            sum += fabs(dist3(x + i, x + i - 3) - rest) / rest;
            m++;
        }
    return m ? sum / (double)m : 0.0;
}

double quality_collider_depth(const core_collider *c, core_xform h, core_vec3 p)
{
    core_vec3 a = core_xform_point(h, c->a);
    switch (c->kind) {
    case CORE_COLLIDER_SPHERE: return (double)c->radius - core_v3_len(core_v3_sub(p, a));
    case CORE_COLLIDER_CAPSULE: {
        core_vec3 b = core_xform_point(h, c->b), ab = core_v3_sub(b, a);
        float ab2 = core_v3_dot(ab, ab);
        float t = ab2 > 0.0f ? core_v3_dot(core_v3_sub(p, a), ab) / ab2 : 0.0f; /* length 0: a sphere */
        t = t < 0.0f ? 0.0f : t > 1.0f ? 1.0f : t;
        return (double)c->radius - core_v3_len(core_v3_sub(p, core_v3_add(a, core_v3_scale(ab, t))));
    }
    case CORE_COLLIDER_ELLIPSOID: {
        core_vec3 u = core_q_rotate(core_q_conj(core_q_mul(h.rot, c->rot)), core_v3_sub(p, a));
        double sx = (double)u.x / c->radii.x, sy = (double)u.y / c->radii.y, sz = (double)u.z / c->radii.z;
        double s = sqrt(sx * sx + sy * sy + sz * sz), ul = core_v3_len(u);
        if (!(s > 1e-12)) { /* at the centre: the nearest surface is the smallest semi-axis away */
            double r = c->radii.x < c->radii.y ? c->radii.x : c->radii.y;
            return r < c->radii.z ? r : c->radii.z;
        }
        return ul * (1.0 - s) / s; /* the surface along the ray through p is at u / s */
    }
    }
    return -INFINITY;
}

/* The character of a groom placed in world space once per frame. */
typedef struct world_shapes {
    core_collider colliders[CORE_MAX_COLLIDERS]; /* moved by the head transform */
    uint32_t ncolliders;
    const core_sdf *sdf; /* the mesh's distance grid (head frame), or NULL */
    core_xform head;     /* moves the grid to world space */
} world_shapes;

static void place_shapes(const core_groom *g, core_xform h, world_shapes *w)
{
    w->sdf = g->sdf;
    w->head = h;
    w->ncolliders = g->ncolliders < CORE_MAX_COLLIDERS ? g->ncolliders : CORE_MAX_COLLIDERS;
    for (uint32_t k = 0; k < w->ncolliders; k++) {
        core_collider c = g->colliders[k];
        c.a = core_xform_point(h, c.a);
        c.b = core_xform_point(h, c.b);
        c.rot = core_q_norm(core_q_mul(h.rot, c.rot));
        w->colliders[k] = c;
    }
}

/* How deep p is inside the mesh's distance grid: minus the sampled distance at p moved to the
 * head frame, for points inside the grid's box (the grid describes the character there only;
 * a region grid cuts the mesh), else -INFINITY. */
static double sdf_depth(const core_sdf *s, core_xform h, core_vec3 p)
{
    const core_vec3 q = core_q_rotate(core_q_conj(h.rot), core_v3_sub(p, h.pos));
    const float c[3] = { q.x, q.y, q.z }, o[3] = { s->origin.x, s->origin.y, s->origin.z };
    for (int a = 0; a < 3; a++)
        if (!(c[a] >= o[a] && c[a] <= o[a] + (float)(s->dims[a] - 1) * s->cell)) return -INFINITY;
    return -(double)core_sdf_sample(s, q, NULL);
}

/* How deep p is inside the character, metres: the deepest of its collision shapes (the
 * colliders, and the mesh's distance grid beyond the depth its rest position r is authored at,
 * sim_groom_contact_floor). */
static double vertex_depth(const world_shapes *w, core_vec3 p, core_vec3 r)
{
    double d = -INFINITY;
    for (uint32_t k = 0; k < w->ncolliders; k++)
        d = worse(d, quality_collider_depth(&w->colliders[k], core_xform_identity(), p));
    if (w->sdf) d = worse(d, sdf_depth(w->sdf, w->head, p) - fmax(sdf_depth(w->sdf, core_xform_identity(), r), 0.0));
    return d;
}

double quality_penetration_max(const core_groom *g, core_xform h, const float *x)
{
    world_shapes w;
    place_shapes(g, h, &w);
    double worst = 0.0;
    for (uint32_t s = 0; s < g->nstrands; s++)
        for (uint32_t v = 1; v < g->nverts; v++) {
            const size_t i = 3 * ((size_t)s * g->nverts + v);
            const float *p = x + i, *r = g->pos + i;
            if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) return NAN;
            worst = worse(worst, vertex_depth(&w, core_v3(p[0], p[1], p[2]), core_v3(r[0], r[1], r[2])));
        }
    return worst;
}

double quality_mean_strand_length(const core_groom *g)
{
    if (g->nstrands == 0) return 0.0;
    double len = 0.0;
    for (uint32_t s = 0; s < g->nstrands; s++)
        for (uint32_t l = 1; l < g->nverts; l++) {
            const float *a = g->pos + 3 * ((size_t)s * g->nverts + l);
            len += dist3(a, a - 3);
        }
    return len / g->nstrands;
}

double quality_shape_deviation(const core_groom *g, core_xform h, const float *x)
{
    double len = quality_mean_strand_length(g), sum = 0.0;
    size_t m = 0;
    if (!(len > 0.0)) return NAN;
    for (uint32_t s = 0; s < g->nstrands; s++)
        for (uint32_t v = 1; v < g->nverts; v++) {
            size_t i = 3 * ((size_t)s * g->nverts + v);
            core_vec3 r = core_xform_point(h, core_v3(g->pos[i], g->pos[i + 1], g->pos[i + 2]));
            const float rf[3] = { r.x, r.y, r.z };
            sum += dist3(x + i, rf);
            m++;
        }
    return m ? sum / (double)m / len : 0.0;
}

double quality_tips_above_roots(const float *x, uint32_t nstrands, uint32_t nverts)
{
    if (nstrands == 0 || nverts == 0) return 0.0;
    uint32_t above = 0;
    for (uint32_t s = 0; s < nstrands; s++) {
        const float *root = x + 3 * (size_t)s * nverts, *tip = root + 3 * (size_t)(nverts - 1);
        if (tip[1] > root[1]) above++;
    }
    return (double)above / nstrands;
}

/* ---- nearest vertex of another strand: a uniform grid, hashed, counting-sorted ---- */

typedef struct nn_grid {
    double lo[3], cell;
    int32_t dim[3];           /* cells per axis */
    uint32_t mask;            /* hash table size - 1 */
    uint32_t *start;          /* mask + 2 entries: bucket b holds order[start[b] .. start[b+1]) */
    uint32_t *order;          /* vertex indices sorted by bucket */
} nn_grid;

static uint32_t nn_hash(const nn_grid *gr, int32_t ix, int32_t iy, int32_t iz)
{
    return (((uint32_t)ix * 73856093u) ^ ((uint32_t)iy * 19349663u) ^ ((uint32_t)iz * 83492791u)) & gr->mask;
}

static void nn_cell(const nn_grid *gr, const float *p, int32_t c[3])
{
    for (int a = 0; a < 3; a++) {
        double f = floor(((double)p[a] - gr->lo[a]) / gr->cell);
        c[a] = f < 0.0 ? 0 : f >= gr->dim[a] ? gr->dim[a] - 1 : (int32_t)f;
    }
}

/* Visits the bucket of cell (ix, iy, iz) for vertex i of strand si: lowers *best2. */
static void nn_visit(const nn_grid *gr, const float *x, uint32_t nverts, size_t i, int32_t ix, int32_t iy, int32_t iz,
                     double *best2)
{
    if (ix < 0 || iy < 0 || iz < 0 || ix >= gr->dim[0] || iy >= gr->dim[1] || iz >= gr->dim[2]) return;
    uint32_t b = nn_hash(gr, ix, iy, iz), si = (uint32_t)(i / nverts);
    const float *p = x + 3 * i;
    for (uint32_t k = gr->start[b]; k < gr->start[b + 1]; k++) {
        uint32_t j = gr->order[k];
        if (j / nverts == si) continue;
        const float *q = x + 3 * (size_t)j;
        double dx = (double)p[0] - q[0], dy = (double)p[1] - q[1], dz = (double)p[2] - q[2];
        double d2 = dx * dx + dy * dy + dz * dz;
        if (d2 < *best2) *best2 = d2;
    }
}

/* Distance from vertex i to the nearest vertex of another strand: rings of cells at Chebyshev
 * distance r = 0, 1, ... A point r + 1 or more cells away is at least r * cell away, so the
 * search stops after ring r once the best distance is <= r * cell. */
static double nn_search(const nn_grid *gr, const float *x, uint32_t nverts, size_t i)
{
    int32_t c[3];
    nn_cell(gr, x + 3 * i, c);
    int32_t rmax = gr->dim[0] > gr->dim[1] ? gr->dim[0] : gr->dim[1];
    rmax = rmax > gr->dim[2] ? rmax : gr->dim[2];
    double best2 = INFINITY;
    for (int32_t r = 0; r <= rmax; r++) {
        for (int32_t dx = -r; dx <= r; dx++)
            for (int32_t dy = -r; dy <= r; dy++) {
                bool face = dx == -r || dx == r || dy == -r || dy == r;
                int32_t step = face ? 1 : (r > 0 ? 2 * r : 1);
                for (int32_t dz = -r; dz <= r; dz += step)
                    nn_visit(gr, x, nverts, i, c[0] + dx, c[1] + dy, c[2] + dz, &best2);
            }
        double reach = (double)r * gr->cell;
        if (best2 <= reach * reach) break;
    }
    return sqrt(best2);
}

core_status quality_nn_other_strand_mean(const float *x, uint32_t nstrands, uint32_t nverts, double *out,
                                         core_err *err)
{
    *out = NAN;
    if (nstrands < 2 || nverts < 1)
        return core_fail(err, CORE_EINVAL, "nearest other strand: needs 2 strands or more, got %u x %u", nstrands,
                         nverts);
    size_t n = (size_t)nstrands * nverts;
    if (n > UINT32_MAX / 4) return core_fail(err, CORE_EINVAL, "nearest other strand: %zu vertices is too many", n);
    nn_grid gr = { .lo = { INFINITY, INFINITY, INFINITY } };
    double hi[3] = { -INFINITY, -INFINITY, -INFINITY }, seg = 0.0;
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            if (!isfinite(x[3 * i + a])) return CORE_OK; /* *out stays NaN */
            if (x[3 * i + a] < gr.lo[a]) gr.lo[a] = x[3 * i + a];
            if (x[3 * i + a] > hi[a]) hi[a] = x[3 * i + a];
        }
    for (uint32_t s = 0; s < nstrands; s++)
        for (uint32_t v = 1; v < nverts; v++) seg += dist3(x + 3 * ((size_t)s * nverts + v), x + 3 * ((size_t)s * nverts + v - 1));
    double extent = 0.0;
    for (int a = 0; a < 3; a++) extent = hi[a] - gr.lo[a] > extent ? hi[a] - gr.lo[a] : extent;
    gr.cell = nverts > 1 ? seg / ((double)nstrands * (nverts - 1)) : extent / cbrt((double)n);
    if (!(gr.cell >= extent / 4096.0)) gr.cell = extent / 4096.0; /* at most 4096 cells an axis */
    if (!(gr.cell > 0.0)) gr.cell = 1.0;                           /* every vertex at one point */
    for (int a = 0; a < 3; a++) gr.dim[a] = (int32_t)floor((hi[a] - gr.lo[a]) / gr.cell) + 1;
    uint32_t size = 1;
    while (size < 2 * n) size <<= 1;
    gr.mask = size - 1;
    gr.start = calloc((size_t)size + 1, sizeof *gr.start);
    gr.order = malloc(n * sizeof *gr.order);
    uint32_t *bucket = malloc(n * sizeof *bucket);
    if (!gr.start || !gr.order || !bucket) {
        free(gr.start);
        free(gr.order);
        free(bucket);
        return core_fail(err, CORE_ENOMEM, "nearest other strand: out of memory for %zu vertices", n);
    }
    for (size_t i = 0; i < n; i++) { /* counting sort by bucket */
        int32_t c[3];
        nn_cell(&gr, x + 3 * i, c);
        bucket[i] = nn_hash(&gr, c[0], c[1], c[2]);
        gr.start[bucket[i] + 1]++;
    }
    for (uint32_t b = 0; b < size; b++) gr.start[b + 1] += gr.start[b]; /* start[b]: first of b */
    for (size_t i = 0; i < n; i++) gr.order[gr.start[bucket[i]]++] = (uint32_t)i; /* start[b]: end of b */
    for (uint32_t b = size; b > 0; b--) gr.start[b] = gr.start[b - 1];             /* back to the first */
    gr.start[0] = 0;
    free(bucket);
    double sum = 0.0;
    for (size_t i = 0; i < n; i++) sum += nn_search(&gr, x, nverts, i);
    free(gr.start);
    free(gr.order);
    *out = sum / (double)n;
    return CORE_OK;
}
