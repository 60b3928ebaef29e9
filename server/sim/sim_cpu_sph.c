/* sim: the CPU SPH stage: hash grid, stable counting sort, capped neighbours, density, forces. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sim_cpu_internal.h"

/* Reference frame time of the pressure scale: accelerations are h / (1/60 s)^2 per unit. */
#define SPH_ACCEL_SCALE 3600.0f
/* Candidates examined per particle beyond which the densest cells are not searched further. */
#define SPH_MAX_CANDIDATES 4096

typedef struct sph_ctx {
    sim_cpu *c;
    float *const *pos;
    float *const *vel;
    float dt;
    float bmin[256][3], bmax[256][3];
} sph_ctx;

void sim_cpu_sph_free(sim_cpu_sph *s)
{
    free(s->cell);
    free(s->order);
    free(s->strand);
    free(s->sp);
    free(s->sv);
    free(s->rho);
    free(s->press);
    free(s->nbr);
    free(s->nnbr);
    free(s->cell_start);
    free(s->hist);
    memset(s, 0, sizeof *s);
}

static core_status sph_reserve(sim_cpu_sph *s, size_t n, int cap, size_t cells, int nthreads, core_err *err)
{
    if (s->n < n || s->cap < cap) {
        free(s->cell), free(s->order), free(s->strand), free(s->sp), free(s->sv);
        free(s->rho), free(s->press), free(s->nbr), free(s->nnbr);
        s->cell = malloc(n * sizeof *s->cell);
        s->order = malloc(n * sizeof *s->order);
        s->strand = malloc(n * sizeof *s->strand);
        s->sp = malloc(n * 4 * sizeof *s->sp);
        s->sv = malloc(n * 4 * sizeof *s->sv);
        s->rho = malloc(n * sizeof *s->rho);
        s->press = malloc(n * sizeof *s->press);
        s->nbr = malloc(n * (size_t)cap * sizeof *s->nbr);
        s->nnbr = malloc(n * sizeof *s->nnbr);
        s->n = n;
        s->cap = cap;
        if (!s->cell || !s->order || !s->strand || !s->sp || !s->sv || !s->rho || !s->press || !s->nbr || !s->nnbr) {
            sim_cpu_sph_free(s);
            return core_fail(err, CORE_ENOMEM, "out of memory for SPH buffers of %zu particles", n);
        }
    }
    size_t need = cells * (size_t)nthreads;
    if (s->cells_cap < need) {
        free(s->cell_start), free(s->hist);
        s->cell_start = malloc((need + 1) * sizeof *s->cell_start);
        s->hist = malloc(need * sizeof *s->hist);
        s->cells_cap = need;
        if (!s->cell_start || !s->hist) {
            sim_cpu_sph_free(s);
            return core_fail(err, CORE_ENOMEM, "out of memory for an SPH grid of %zu cells", cells);
        }
    }
    return CORE_OK;
}

static void bounds_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    size_t b, e;
    sim_pool_range(ctx->c->n, tid, nt, 64, &b, &e);
    float lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (int k = 0; k < 3; k++) {
        const float *p = ctx->pos[k];
        for (size_t i = b; i < e; i++) {
            lo[k] = fminf(lo[k], p[i]);
            hi[k] = fmaxf(hi[k], p[i]);
        }
        ctx->bmin[tid][k] = lo[k];
        ctx->bmax[tid][k] = hi[k];
    }
}

static inline uint32_t cell_coord(float p, float origin, float inv, uint32_t dim)
{
    float f = (p - origin) * inv;
    if (!(f > 0.0f)) return 0; /* also catches NaN */
    return f >= (float)(dim - 1) ? dim - 1 : (uint32_t)f;
}

static void count_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu_sph *s = &ctx->c->sph;
    size_t b, e;
    sim_pool_range(ctx->c->n, tid, nt, 64, &b, &e);
    uint32_t *hist = s->hist + (size_t)tid * s->ncells;
    memset(hist, 0, s->ncells * sizeof *hist);
    for (size_t i = b; i < e; i++) {
        uint32_t cx = cell_coord(ctx->pos[0][i], s->origin[0], s->inv_cell, s->dims[0]);
        uint32_t cy = cell_coord(ctx->pos[1][i], s->origin[1], s->inv_cell, s->dims[1]);
        uint32_t cz = cell_coord(ctx->pos[2][i], s->origin[2], s->inv_cell, s->dims[2]);
        uint32_t cell = (cz * s->dims[1] + cy) * s->dims[0] + cx;
        s->cell[i] = cell;
        hist[cell]++;
    }
}

static void scan_sum_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu_sph *s = &ctx->c->sph;
    size_t b, e, sum = 0;
    sim_pool_range(s->ncells, tid, nt, 64, &b, &e);
    for (int t = 0; t < nt; t++) {
        const uint32_t *h = s->hist + (size_t)t * s->ncells;
        for (size_t k = b; k < e; k++) sum += h[k];
    }
    s->tsum[tid] = sum;
}

static void scan_fill_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu_sph *s = &ctx->c->sph;
    size_t b, e, run = 0;
    for (int t = 0; t < tid; t++) run += s->tsum[t];
    sim_pool_range(s->ncells, tid, nt, 64, &b, &e);
    for (size_t k = b; k < e; k++) {
        s->cell_start[k] = (uint32_t)run;
        for (int t = 0; t < nt; t++) {
            uint32_t *h = s->hist + (size_t)t * s->ncells + k;
            uint32_t cnt = *h;
            *h = (uint32_t)run;
            run += cnt;
        }
    }
}

static void scatter_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu *c = ctx->c;
    sim_cpu_sph *s = &c->sph;
    size_t b, e;
    sim_pool_range(c->n, tid, nt, 64, &b, &e);
    uint32_t *cursor = s->hist + (size_t)tid * s->ncells;
    for (size_t i = b; i < e; i++) {
        uint32_t slot = cursor[s->cell[i]]++;
        s->order[slot] = (uint32_t)i;
        s->strand[slot] = (uint32_t)(i % c->ns);
        for (int k = 0; k < 3; k++) {
            s->sp[4 * (size_t)slot + k] = ctx->pos[k][i];
            s->sv[4 * (size_t)slot + k] = ctx->vel ? ctx->vel[k][i] : 0.0f;
        }
        s->sp[4 * (size_t)slot + 3] = 0.0f;
        s->sv[4 * (size_t)slot + 3] = 0.0f;
    }
}

/* Max-heap on (r2, slot) holding the cap nearest candidates. */
typedef struct nbr_heap {
    float r2[64];
    uint32_t slot[64];
    int n, cap;
} nbr_heap;

static inline int heap_less(const nbr_heap *h, int a, int b)
{
    return h->r2[a] < h->r2[b] || (h->r2[a] == h->r2[b] && h->slot[a] < h->slot[b]);
}

static inline void heap_swap(nbr_heap *h, int a, int b)
{
    float r = h->r2[a];
    uint32_t s = h->slot[a];
    h->r2[a] = h->r2[b], h->slot[a] = h->slot[b];
    h->r2[b] = r, h->slot[b] = s;
}

static void heap_offer(nbr_heap *h, float r2, uint32_t slot)
{
    if (h->n < h->cap) {
        int i = h->n++;
        h->r2[i] = r2, h->slot[i] = slot;
        while (i > 0 && heap_less(h, (i - 1) / 2, i)) {
            heap_swap(h, i, (i - 1) / 2);
            i = (i - 1) / 2;
        }
        return;
    }
    if (!(r2 < h->r2[0] || (r2 == h->r2[0] && slot < h->slot[0]))) return;
    h->r2[0] = r2, h->slot[0] = slot;
    int i = 0;
    for (;;) {
        int l = 2 * i + 1, r = l + 1, m = i;
        if (l < h->n && heap_less(h, m, l)) m = l;
        if (r < h->n && heap_less(h, m, r)) m = r;
        if (m == i) break;
        heap_swap(h, i, m);
        i = m;
    }
}

/* Neighbour search and density for every particle of the cells in this worker's range. */
static void density_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu *c = ctx->c;
    sim_cpu_sph *s = &c->sph;
    const float h = c->params.sph_radius, h2 = h * h, inv_h2 = 1.0f / h2;
    const int cap = c->params.neighbor_cap;
    const uint32_t dx = s->dims[0], dy = s->dims[1], dz = s->dims[2];
    size_t b, e;
    sim_pool_range(s->ncells, tid, nt, 1, &b, &e);
    nbr_heap heap;
    heap.cap = cap;
    for (size_t cell = b; cell < e; cell++) {
        uint32_t first = s->cell_start[cell], last = cell + 1 < s->ncells ? s->cell_start[cell + 1] : (uint32_t)c->n;
        if (first == last) continue;
        uint32_t cx = (uint32_t)(cell % dx), cy = (uint32_t)(cell / dx % dy), cz = (uint32_t)(cell / dx / dy);
        /* the 9 rows of 3 x-adjacent cells around this cell are contiguous in sorted order */
        uint32_t rb[9], re[9];
        int nrows = 0;
        uint32_t x0 = cx > 0 ? cx - 1 : 0, x1 = cx + 1 < dx ? cx + 1 : dx - 1;
        for (int oz = -1; oz <= 1; oz++) {
            if ((oz < 0 && cz == 0) || (oz > 0 && cz + 1 >= dz)) continue;
            for (int oy = -1; oy <= 1; oy++) {
                if ((oy < 0 && cy == 0) || (oy > 0 && cy + 1 >= dy)) continue;
                size_t row = ((size_t)(cz + (uint32_t)oz) * dy + (cy + (uint32_t)oy)) * dx;
                size_t lo = row + x0, hi = row + x1 + 1;
                rb[nrows] = s->cell_start[lo];
                re[nrows] = hi < s->ncells ? s->cell_start[hi] : (uint32_t)c->n;
                nrows++;
            }
        }
        for (uint32_t i = first; i < last; i++) {
            const float xi = s->sp[4 * (size_t)i], yi = s->sp[4 * (size_t)i + 1], zi = s->sp[4 * (size_t)i + 2];
            const uint32_t si = s->strand[i];
            heap.n = 0;
            size_t examined = 0;
            for (int r = 0; r < nrows && examined < SPH_MAX_CANDIDATES; r++) {
                examined += re[r] - rb[r];
                for (uint32_t j = rb[r]; j < re[r]; j++) {
                    float ddx = s->sp[4 * (size_t)j] - xi, ddy = s->sp[4 * (size_t)j + 1] - yi,
                          ddz = s->sp[4 * (size_t)j + 2] - zi;
                    float r2 = ddx * ddx + ddy * ddy + ddz * ddz;
                    if (r2 < h2 && s->strand[j] != si) heap_offer(&heap, r2, j);
                }
            }
            float rho = 1.0f;
            uint32_t *out = s->nbr + (size_t)i * (size_t)cap;
            for (int k = 0; k < heap.n; k++) {
                float q = 1.0f - heap.r2[k] * inv_h2;
                rho += q * q * q;
                out[k] = heap.slot[k];
            }
            s->nnbr[i] = (uint8_t)heap.n;
            s->rho[i] = rho;
        }
    }
}

static void pressure_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu *c = ctx->c;
    sim_cpu_sph *s = &c->sph;
    size_t b, e;
    sim_pool_range(c->n, tid, nt, 64, &b, &e);
    const float inv_rho0 = 1.0f / (c->params.rest_density * c->rho_rest);
    for (size_t i = b; i < e; i++) s->press[i] = fmaxf(s->rho[i] * inv_rho0 - 1.0f, 0.0f);
}

static void force_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu *c = ctx->c;
    sim_cpu_sph *s = &c->sph;
    const float h = c->params.sph_radius, inv_h = 1.0f / h;
    const float kp = c->params.repulsion * h * SPH_ACCEL_SCALE;
    const float mu_dt = c->params.viscosity * ctx->dt, inv_dt = 1.0f / ctx->dt;
    const int cap = c->params.neighbor_cap;
    size_t b, e;
    sim_pool_range(c->n, tid, nt, 64, &b, &e);
    for (size_t i = b; i < e; i++) {
        const float *pi = s->sp + 4 * i, *vi = s->sv + 4 * i;
        const float Pi = s->press[i];
        float apx = 0.0f, apy = 0.0f, apz = 0.0f, W = 0.0f, vbx = 0.0f, vby = 0.0f, vbz = 0.0f;
        const uint32_t *nb = s->nbr + i * (size_t)cap;
        for (int k = 0; k < s->nnbr[i]; k++) {
            const uint32_t j = nb[k];
            const float *pj = s->sp + 4 * (size_t)j, *vj = s->sv + 4 * (size_t)j;
            float dx = pi[0] - pj[0], dy = pi[1] - pj[1], dz = pi[2] - pj[2];
            float r = sqrtf(dx * dx + dy * dy + dz * dz);
            float q = 1.0f - r * inv_h;
            float inv_rhoj = 1.0f / s->rho[j];
            if (r > 1e-9f) {
                float f = (Pi + s->press[j]) * 0.5f * inv_rhoj * q * q / r;
                apx += f * dx, apy += f * dy, apz += f * dz;
            }
            float w = q * inv_rhoj;
            W += w;
            vbx += w * vj[0], vby += w * vj[1], vbz += w * vj[2];
        }
        float ax = 0.0f, ay = 0.0f, az = 0.0f;
        if (W > 0.0f) {
            float kr = kp / s->rho[i];
            ax = apx * kr, ay = apy * kr, az = apz * kr;
            float blend = (1.0f - expf(-mu_dt * W / (1.0f + W))) * inv_dt;
            ax += blend * (vbx / W - vi[0]);
            ay += blend * (vby / W - vi[1]);
            az += blend * (vbz / W - vi[2]);
        }
        const uint32_t o = s->order[i];
        c->a[0][o] = ax, c->a[1][o] = ay, c->a[2][o] = az;
    }
}

core_status sim_cpu_sph_pass(sim_cpu *c, float *const pos[3], float *const vel[3], float dt, double *out_mean_rho,
                             core_err *err)
{
    sph_ctx *ctx = calloc(1, sizeof *ctx);
    if (!ctx) return core_fail(err, CORE_ENOMEM, "out of memory");
    ctx->c = c;
    ctx->pos = pos;
    ctx->vel = vel;
    ctx->dt = dt;
    sim_cpu_sph *s = &c->sph;
    int nt = c->pool.nthreads;
    sim_pool_run(&c->pool, bounds_job, ctx);
    float lo[3], hi[3];
    for (int k = 0; k < 3; k++) {
        lo[k] = ctx->bmin[0][k], hi[k] = ctx->bmax[0][k];
        for (int t = 1; t < nt; t++) lo[k] = fminf(lo[k], ctx->bmin[t][k]), hi[k] = fmaxf(hi[k], ctx->bmax[t][k]);
        if (!isfinite(lo[k]) || !isfinite(hi[k])) lo[k] = hi[k] = 0.0f; /* non-finite strands are reset after */
    }
    /* cell = h, grown when the box would need more cells than the budget (still correct:
     * neighbours within h lie in the 27 surrounding cells for any cell >= h) */
    size_t budget = c->n * 8 > (1u << 18) ? c->n * 8 : (1u << 18);
    float cell = c->params.sph_radius;
    for (;;) {
        double cells = 1.0;
        for (int k = 0; k < 3; k++) cells *= floor((double)(hi[k] - lo[k]) / cell) + 1.0;
        if (cells <= (double)budget) break;
        cell *= (float)cbrt(cells / (double)budget) * 1.01f;
    }
    s->cell_size = cell;
    s->inv_cell = 1.0f / cell;
    s->ncells = 1;
    for (int k = 0; k < 3; k++) {
        s->origin[k] = lo[k];
        s->dims[k] = (uint32_t)floorf((hi[k] - lo[k]) * s->inv_cell) + 1;
        s->ncells *= s->dims[k];
    }
    core_status st = sph_reserve(s, c->n, c->params.neighbor_cap, s->ncells, nt, err);
    if (st != CORE_OK) {
        free(ctx);
        return st;
    }
    sim_pool_run(&c->pool, count_job, ctx);
    sim_pool_run(&c->pool, scan_sum_job, ctx);
    sim_pool_run(&c->pool, scan_fill_job, ctx);
    sim_pool_run(&c->pool, scatter_job, ctx);
    sim_pool_run(&c->pool, density_job, ctx);
    if (out_mean_rho) {
        double sum = 0.0; /* serial, in sorted order: the same bits for any thread count */
        for (size_t i = 0; i < c->n; i++) sum += s->rho[i];
        *out_mean_rho = sum / (double)c->n;
    } else {
        sim_pool_run(&c->pool, pressure_job, ctx);
        sim_pool_run(&c->pool, force_job, ctx);
    }
    free(ctx);
    return CORE_OK;
}
