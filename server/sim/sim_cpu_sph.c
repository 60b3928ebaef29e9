/* sim: the CPU SPH stage: hash grid, stable counting sort, capped neighbours, density, forces. */
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#ifdef __AVX2__
#include <immintrin.h>
#endif

#include "sim_cpu_internal.h"
#include "sim_mem.h"

/* Candidates within the skin radius kept per particle before the nearest are selected. */
#define SPH_MAX_CANDIDATES 1024
/* Verlet skin, in units of h: the lists hold the neighbour_cap nearest particles within
 * (1 + SPH_SKIN) h, and they are kept while no pair outside a list can have come within h (the
 * kernels are zero beyond h), unless its list was full. Offsets are measured from where the
 * head's rigid motion since the build carried each particle's build position; a pair's distance
 * has changed by at most the difference of its two offsets. They are kept while every offset is
 * below SPH_SKIN h / 2; past that, on an unfolded grid (every cell its own bucket), while every
 * offset is below SPH_REACH h and the offsets of any two particles in the same or neighbouring
 * cells differ by at most SPH_SKIN h (lists_hold): hair that swings together keeps its lists.
 * 0.4 rather than 0.2: with SPH evaluated every second step (sim_step_sph_clock) hair moves twice
 * as far between searches, and under shake and headbang the lists were rebuilt at most
 * evaluations (SPH 8.6 -> 6.7 ms a step under headbang on the default scene; 0.6 gained nothing
 * more). */
#define SPH_SKIN 0.4f
/* Cells are 2 (1 + SPH_SKIN) h wide, so two particles two cells apart were more than that apart
 * at the build: while no offset exceeds (2 (1 + SPH_SKIN) - 1) h / 2 = 0.9 h they have not come
 * within h, and only the cells around each one need the relative check. 1% below, for rounding. */
#define SPH_REACH (0.99f * (1.0f + 2.0f * SPH_SKIN) / 2.0f)
/* A search costs about this times the mean occupancy of the occupied cells as much as a kept
 * pass's boxes and relative check (box_job, cells_check_job): 25 ms against 2.95 at 15,000 x 23,
 * 4.3 particles a cell; 98 against 5.9 at 16,384 x 64 under shake, 10.7 a cell (2 threads). */
#define SPH_CHECK_WORTH 1.75

/* Floats of a cell's record in dbox: the low and high corners of its particles' offsets, the
 * largest squared offset, and padding to 32 bytes. */
#define SPH_BOX 8

/* Pairs of particles the relative check of kept lists may look at one by one, per particle (see
 * cells_check_job): a search measures each particle against every slot of its 2 x 2 x 2 cells
 * (85 at 16,384 x 64), so looking at up to 16 n pairs costs a fraction of the search it spares. */
#define SPH_LOOK_BUDGET 16

/* Elements of padding after the sorted SoA arrays and scan buffers (two AVX2 vectors). */
#define SPH_PAD 16
/* Shares of the per-particle and per-cell passes, taken by whichever worker is free. */
#define SPH_PARTS 64
/* Slots the regather pass refreshes between looks at whether another part found a stray. */
#define SPH_STRAY_BLOCK 1024

#define MAX0(a) ((a) > 0.0f ? (a) : 0.0f)

typedef struct sph_ctx {
    sim_cpu *c;
    float *const *pos;
    float *const *prev;     /* positions at the last evaluation (NULL in the rest pass) */
    float inv_since;        /* velocity = (pos - prev) * inv_since (sim_step_desc.sph_inv_since) */
    float dt;
    bool pressure;          /* the selection pass also sets the pressure (not in the rest pass) */
    float carry[12];        /* rows (m0 m1 m2 t): the head's rigid motion since the lists' build */
    float stray2;           /* the squared bound on a particle's offset from its carried build
                               position: (SPH_REACH h)^2 on an unfolded grid, (SPH_SKIN h / 2)^2
                               otherwise; a particle farther voids the lists */
    atomic_bool strayed;    /* the regather pass found a particle that strayed (the others stop) */
    float half2;            /* (SPH_SKIN h / 2)^2: while no offset is longer, the lists hold */
    atomic_bool beyond;     /* the regather pass found an offset longer than that */
    atomic_long look_budget; /* pairs cells_pair_close may still look at in this pass */
    float bmin[256][3], bmax[256][3];
} sph_ctx;

void sim_cpu_sph_free(sim_cpu_sph *s)
{
    free(s->cell);
    free(s->order);
    free(s->slot_of);
    free(s->strand);
    free(s->sp);
    free(s->sx);
    free(s->sy);
    free(s->sz);
    free(s->sv);
    free(s->nbr);
    free(s->nnbr);
    free(s->cell_start);
    free(s->hist);
    free(s->dbox);
    const bool portable = s->portable;
    memset(s, 0, sizeof *s);
    s->portable = portable;
}

static core_status sph_reserve(sim_cpu_sph *s, size_t n, int cap, size_t cells, int nthreads, core_err *err)
{
    if (s->n < n || s->cap < cap) {
        free(s->cell), free(s->order), free(s->slot_of), free(s->strand), free(s->sp), free(s->sv);
        free(s->sx), free(s->sy), free(s->sz);
        free(s->nbr), free(s->nnbr);
        s->cell = sim_mem_alloc(n * sizeof *s->cell, false);
        s->order = sim_mem_alloc(n * sizeof *s->order, false);
        s->slot_of = sim_mem_alloc(n * sizeof *s->slot_of, false);
        s->strand = sim_mem_alloc((n + SPH_PAD) * sizeof *s->strand, true);
        s->sp = sim_mem_alloc(n * 4 * sizeof *s->sp, false);
        /* padded by SPH_PAD so vector loads of a run's last block stay inside */
        s->sx = sim_mem_alloc((n + SPH_PAD) * sizeof *s->sx, true);
        s->sy = sim_mem_alloc((n + SPH_PAD) * sizeof *s->sy, true);
        s->sz = sim_mem_alloc((n + SPH_PAD) * sizeof *s->sz, true);
        s->sv = sim_mem_alloc(n * 4 * sizeof *s->sv, false);
        s->nbr = sim_mem_alloc((n * (size_t)cap + SPH_PAD) * sizeof *s->nbr, true); /* padded for 8-wide row loads */
        s->nnbr = sim_mem_alloc(n * sizeof *s->nnbr, false);
        s->n = n;
        s->cap = cap;
        if (!s->cell || !s->order || !s->slot_of || !s->strand || !s->sp || !s->sv || !s->sx || !s->sy || !s->sz || !s->nbr || !s->nnbr) {
            sim_cpu_sph_free(s);
            return core_fail(err, CORE_ENOMEM, "out of memory for SPH buffers of %zu particles", n);
        }
    }
    size_t need = cells * (size_t)nthreads;
    if (s->cells_cap < need) {
        free(s->cell_start), free(s->hist);
        s->cell_start = sim_mem_alloc((need + 1) * sizeof *s->cell_start, false);
        s->hist = sim_mem_alloc(need * sizeof *s->hist, false);
        s->cells_cap = need;
        if (!s->cell_start || !s->hist) {
            sim_cpu_sph_free(s);
            return core_fail(err, CORE_ENOMEM, "out of memory for an SPH grid of %zu cells", cells);
        }
    }
    const size_t grid = sim_cpu_sph_grid_cells(s); /* <= cells when unfolded */
    if (sim_cpu_sph_unfolded(s) && s->dbox_cap < grid) {
        free(s->dbox);
        s->dbox = sim_mem_alloc(grid * SPH_BOX * sizeof *s->dbox, false);
        s->dbox_cap = grid;
        if (!s->dbox) {
            sim_cpu_sph_free(s);
            return core_fail(err, CORE_ENOMEM, "out of memory for the offsets of an SPH grid of %zu cells", grid);
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
            lo[k] = p[i] < lo[k] ? p[i] : lo[k]; /* not fminf/fmaxf: these vectorize */
            hi[k] = p[i] > hi[k] ? p[i] : hi[k];
        }
        ctx->bmin[tid][k] = lo[k];
        ctx->bmax[tid][k] = hi[k];
    }
}

static inline uint32_t cell_coord(float p, float origin, float inv)
{
    float f = (p - origin) * inv;
    if (!(f > 0.0f)) return 0; /* also catches NaN */
    return f >= 1048575.0f ? 1048575u : (uint32_t)f;
}

/* The spatial hash: the cell's linear index in the bounding-box grid, folded into the
 * power-of-two table. Unlike a scrambling hash it keeps the three x-neighbours of a cell in
 * consecutive buckets, so a row of cells is one contiguous run of sorted particles. */
static inline uint32_t cell_hash(const sim_cpu_sph *s, uint32_t cx, uint32_t cy, uint32_t cz)
{
    uint64_t lin = ((uint64_t)cz * s->dims[1] + cy) * s->dims[0] + cx;
    return (uint32_t)(lin & (s->ncells - 1));
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
        uint32_t cx = cell_coord(ctx->pos[0][i], s->origin[0], s->inv_cell);
        uint32_t cy = cell_coord(ctx->pos[1][i], s->origin[1], s->inv_cell);
        uint32_t cz = cell_coord(ctx->pos[2][i], s->origin[2], s->inv_cell);
        uint32_t bucket = cell_hash(s, cx, cy, cz);
        s->cell[i] = bucket;
        hist[bucket]++;
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
    size_t b, e, run = 0, occupied = 0;
    for (int t = 0; t < tid; t++) run += s->tsum[t];
    sim_pool_range(s->ncells, tid, nt, 64, &b, &e);
    for (size_t k = b; k < e; k++) {
        const size_t was = run;
        s->cell_start[k] = (uint32_t)run;
        for (int t = 0; t < nt; t++) {
            uint32_t *h = s->hist + (size_t)t * s->ncells + k;
            uint32_t cnt = *h;
            *h = (uint32_t)run;
            run += cnt;
        }
        occupied += run != was;
    }
    s->tocc[tid] = occupied;
    if (tid == nt - 1) s->cell_start[s->ncells] = (uint32_t)run;
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
        s->slot_of[i] = slot;
        s->strand[slot] = (uint32_t)(i % c->ns);
    }
}

#ifdef __AVX2__
/* For each 8-bit lane mask, the indices of its set lanes packed low to high, 4 bits each:
 * the permutation that compacts the selected lanes of a vector to its front. */
static const uint32_t compact_lut[256] = {
    0x00000000, 0x00000000, 0x00000001, 0x00000010, 0x00000002, 0x00000020, 0x00000021, 0x00000210,
    0x00000003, 0x00000030, 0x00000031, 0x00000310, 0x00000032, 0x00000320, 0x00000321, 0x00003210,
    0x00000004, 0x00000040, 0x00000041, 0x00000410, 0x00000042, 0x00000420, 0x00000421, 0x00004210,
    0x00000043, 0x00000430, 0x00000431, 0x00004310, 0x00000432, 0x00004320, 0x00004321, 0x00043210,
    0x00000005, 0x00000050, 0x00000051, 0x00000510, 0x00000052, 0x00000520, 0x00000521, 0x00005210,
    0x00000053, 0x00000530, 0x00000531, 0x00005310, 0x00000532, 0x00005320, 0x00005321, 0x00053210,
    0x00000054, 0x00000540, 0x00000541, 0x00005410, 0x00000542, 0x00005420, 0x00005421, 0x00054210,
    0x00000543, 0x00005430, 0x00005431, 0x00054310, 0x00005432, 0x00054320, 0x00054321, 0x00543210,
    0x00000006, 0x00000060, 0x00000061, 0x00000610, 0x00000062, 0x00000620, 0x00000621, 0x00006210,
    0x00000063, 0x00000630, 0x00000631, 0x00006310, 0x00000632, 0x00006320, 0x00006321, 0x00063210,
    0x00000064, 0x00000640, 0x00000641, 0x00006410, 0x00000642, 0x00006420, 0x00006421, 0x00064210,
    0x00000643, 0x00006430, 0x00006431, 0x00064310, 0x00006432, 0x00064320, 0x00064321, 0x00643210,
    0x00000065, 0x00000650, 0x00000651, 0x00006510, 0x00000652, 0x00006520, 0x00006521, 0x00065210,
    0x00000653, 0x00006530, 0x00006531, 0x00065310, 0x00006532, 0x00065320, 0x00065321, 0x00653210,
    0x00000654, 0x00006540, 0x00006541, 0x00065410, 0x00006542, 0x00065420, 0x00065421, 0x00654210,
    0x00006543, 0x00065430, 0x00065431, 0x00654310, 0x00065432, 0x00654320, 0x00654321, 0x06543210,
    0x00000007, 0x00000070, 0x00000071, 0x00000710, 0x00000072, 0x00000720, 0x00000721, 0x00007210,
    0x00000073, 0x00000730, 0x00000731, 0x00007310, 0x00000732, 0x00007320, 0x00007321, 0x00073210,
    0x00000074, 0x00000740, 0x00000741, 0x00007410, 0x00000742, 0x00007420, 0x00007421, 0x00074210,
    0x00000743, 0x00007430, 0x00007431, 0x00074310, 0x00007432, 0x00074320, 0x00074321, 0x00743210,
    0x00000075, 0x00000750, 0x00000751, 0x00007510, 0x00000752, 0x00007520, 0x00007521, 0x00075210,
    0x00000753, 0x00007530, 0x00007531, 0x00075310, 0x00007532, 0x00075320, 0x00075321, 0x00753210,
    0x00000754, 0x00007540, 0x00007541, 0x00075410, 0x00007542, 0x00075420, 0x00075421, 0x00754210,
    0x00007543, 0x00075430, 0x00075431, 0x00754310, 0x00075432, 0x00754320, 0x00754321, 0x07543210,
    0x00000076, 0x00000760, 0x00000761, 0x00007610, 0x00000762, 0x00007620, 0x00007621, 0x00076210,
    0x00000763, 0x00007630, 0x00007631, 0x00076310, 0x00007632, 0x00076320, 0x00076321, 0x00763210,
    0x00000764, 0x00007640, 0x00007641, 0x00076410, 0x00007642, 0x00076420, 0x00076421, 0x00764210,
    0x00007643, 0x00076430, 0x00076431, 0x00764310, 0x00076432, 0x00764320, 0x00764321, 0x07643210,
    0x00000765, 0x00007650, 0x00007651, 0x00076510, 0x00007652, 0x00076520, 0x00076521, 0x00765210,
    0x00007653, 0x00076530, 0x00076531, 0x00765310, 0x00076532, 0x00765320, 0x00765321, 0x07653210,
    0x00007654, 0x00076540, 0x00076541, 0x00765410, 0x00076542, 0x00765420, 0x00765421, 0x07654210,
    0x00076543, 0x00765430, 0x00765431, 0x07654310, 0x00765432, 0x07654320, 0x07654321, 0x76543210,
};
#endif

/* The candidate scan of one run [rb, re) of sorted slots: appends to r2s[]/idx[] the slots j
 * within h (r2 < h2) of another strand than si, in slot order, taking blocks of 8 slots from rb
 * while fewer than SPH_MAX_CANDIDATES are held; returns the new count. The buffers need 16
 * spare entries. r2 = (dx*dx + dy*dy) + dz*dz in both paths, so AVX2 and scalar code give the
 * same lists. */
static size_t scan_run(const sim_cpu_sph *s, uint32_t rb, uint32_t re, float x, float y, float z, float h2,
                       uint32_t si, float *r2s, uint32_t *idx, size_t m)
{
#ifdef __AVX2__
    if (!s->portable) {
        const __m256 vx = _mm256_set1_ps(x), vy = _mm256_set1_ps(y), vz = _mm256_set1_ps(z), vh2 = _mm256_set1_ps(h2);
        const __m256i vsi = _mm256_set1_epi32((int)si);
        const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        const __m256i nibbles = _mm256_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28);
        uint32_t j = rb;
#ifdef __AVX512VL__
        /* Blocks of 16 slots (two of 8 at once) while both halves would be taken: below
         * SPH_MAX_CANDIDATES - 8 the first half cannot reach the limit, so the 8-slot blocks
         * below take the rest from j and the list is the same. Compressed in registers (a
         * compressing store to memory is microcoded). */
        const __m512 wx = _mm512_set1_ps(x), wy = _mm512_set1_ps(y), wz = _mm512_set1_ps(z), wh2 = _mm512_set1_ps(h2);
        const __m512i wsi = _mm512_set1_epi32((int)si);
        const __m512i lanes16 = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
        for (; (j == rb || j < re) && m < SPH_MAX_CANDIDATES - 8; j += 16) {
            __m512 dx = _mm512_sub_ps(_mm512_loadu_ps(s->sx + j), wx);
            __m512 dy = _mm512_sub_ps(_mm512_loadu_ps(s->sy + j), wy);
            __m512 dz = _mm512_sub_ps(_mm512_loadu_ps(s->sz + j), wz);
            __m512 r2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)), _mm512_mul_ps(dz, dz));
            __mmask16 ok = _mm512_cmpgt_epi32_mask(_mm512_set1_epi32((int)re - (int)j), lanes16);
            ok = _mm512_mask_cmpneq_epi32_mask(ok, _mm512_loadu_si512(s->strand + j), wsi);
            ok = _mm512_mask_cmp_ps_mask(ok, r2, wh2, _CMP_LT_OQ);
            _mm512_storeu_ps(r2s + m, _mm512_maskz_compress_ps(ok, r2));
            _mm512_storeu_si512(idx + m, _mm512_maskz_compress_epi32(ok, _mm512_add_epi32(_mm512_set1_epi32((int)j), lanes16)));
            m += (size_t)__builtin_popcount((unsigned)ok);
        }
#endif
        /* The first two blocks come without a loop (most runs hold at most 16 slots; a loop
         * whose trip count changes from run to run costs a branch miss per run). A block may
         * start past re (its lanes are all masked); the arrays are padded by SPH_PAD. */
        for (; (j < rb + 16 || j < re) && m < SPH_MAX_CANDIDATES; j += 8) {
            __m256 dx = _mm256_sub_ps(_mm256_loadu_ps(s->sx + j), vx);
            __m256 dy = _mm256_sub_ps(_mm256_loadu_ps(s->sy + j), vy);
            __m256 dz = _mm256_sub_ps(_mm256_loadu_ps(s->sz + j), vz);
            __m256 r2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
            __m256i same = _mm256_cmpeq_epi32(_mm256_loadu_si256((const __m256i *)(s->strand + j)), vsi);
            __m256i inside = _mm256_cmpgt_epi32(_mm256_set1_epi32((int)re - (int)j), lanes);
            __m256 ok = _mm256_andnot_ps(_mm256_castsi256_ps(same), _mm256_castsi256_ps(inside));
            unsigned mask = (unsigned)_mm256_movemask_ps(_mm256_and_ps(ok, _mm256_cmp_ps(r2, vh2, _CMP_LT_OQ)));
            /* branch-free: store the compacted lanes, advance by the number selected */
            __m256i perm = _mm256_and_si256(_mm256_srlv_epi32(_mm256_set1_epi32((int)compact_lut[mask]), nibbles),
                                            _mm256_set1_epi32(15));
            _mm256_storeu_ps(r2s + m, _mm256_permutevar8x32_ps(r2, perm));
            __m256i slots = _mm256_add_epi32(_mm256_set1_epi32((int)j), lanes);
            _mm256_storeu_si256((__m256i *)(idx + m), _mm256_permutevar8x32_epi32(slots, perm));
            m += (size_t)__builtin_popcount(mask);
        }
        return m;
    }
#endif
    for (uint32_t j0 = rb; j0 < re && m < SPH_MAX_CANDIDATES; j0 += 8)
        for (uint32_t j = j0; j < j0 + 8 && j < re; j++) {
            float dx = s->sx[j] - x, dy = s->sy[j] - y, dz = s->sz[j] - z;
            float r2 = (dx * dx + dy * dy) + dz * dz;
            r2s[m] = r2;
            idx[m] = j;
            m += (r2 < h2) & (s->strand[j] != si);
        }
    return m;
}

static inline void swap_u64(uint64_t *a, uint64_t *b)
{
    uint64_t t = *a;
    *a = *b, *b = t;
}

/* Reorders the distinct keys[0, n) so that the k smallest come first (quickselect with a
 * median-of-three pivot; deterministic). */
static void select_smallest(uint64_t *keys, size_t n, size_t k)
{
    size_t lo = 0, hi = n;
    while (hi - lo > 1 && k > lo && k < hi) {
        size_t mid = lo + (hi - lo) / 2, last = hi - 1;
        if (keys[mid] < keys[lo]) swap_u64(&keys[mid], &keys[lo]);
        if (keys[last] < keys[lo]) swap_u64(&keys[last], &keys[lo]);
        if (keys[mid] < keys[last]) swap_u64(&keys[mid], &keys[last]); /* median now at last */
        const uint64_t pivot = keys[last];
        size_t store = lo;
        for (size_t i = lo; i < last; i++)
            if (keys[i] < pivot) swap_u64(&keys[i], &keys[store++]);
        swap_u64(&keys[store], &keys[last]);
        if (store == k) break;
        if (k < store) hi = store;
        else lo = store + 1;
    }
}

/* The lower corner, along one axis, of the 2 cells (of size 2h) that hold every point within h
 * of p: the cell of p and the neighbour on the side of the half p lies in. */
static inline uint32_t lower_cell(float p, float origin, float inv)
{
    float f = (p - origin) * inv;
    uint32_t c = cell_coord(p, origin, inv);
    return f - (float)c < 0.5f ? c - 1 : c;
}

/* The bucket ranges [lo, hi] covering the 2x2x2 cells from corner (x0,y0,z0): one run of two
 * buckets per row of x-neighbours (split where the fold wraps), sorted and merged so no
 * bucket is visited twice. Returns the number of ranges. */
static int neighbour_ranges(const sim_cpu_sph *s, uint32_t x0, uint32_t y0, uint32_t z0, uint32_t lo[8],
                            uint32_t hi[8])
{
    const uint32_t mask = (uint32_t)s->ncells - 1;
    int n = 0;
    for (uint32_t z = z0; z != z0 + 2; z++)
        for (uint32_t y = y0; y != y0 + 2; y++) {
            uint32_t a = cell_hash(s, x0, y, z), b = (a + 1) & mask;
            uint32_t seg_lo[2] = { a, 0 }, seg_hi[2] = { b, b };
            int segs = 1;
            if (b < a) { /* wrapped: [a, mask] and [0, b] */
                seg_hi[0] = mask;
                segs = 2;
            }
            for (int k = 0; k < segs; k++) {
                int i = n++;
                while (i > 0 && lo[i - 1] > seg_lo[k]) { /* insertion keeps them sorted by lo */
                    lo[i] = lo[i - 1], hi[i] = hi[i - 1];
                    i--;
                }
                lo[i] = seg_lo[k], hi[i] = seg_hi[k];
            }
        }
    int m = 0;
    for (int k = 0; k < n; k++) {
        if (m > 0 && lo[k] <= hi[m - 1] + 1) {
            if (hi[k] > hi[m - 1]) hi[m - 1] = hi[k];
        } else {
            lo[m] = lo[k], hi[m] = hi[k];
            m++;
        }
    }
    return m;
}

/* The density kernel of a neighbour at squared distance r2: q^3 with q = max(1 - r2 / h^2, 0). */
static inline float density_term(float r2, float inv_h2)
{
    const float q = MAX0(1.0f - r2 * inv_h2);
    return q * q * q;
}

#ifdef __AVX2__
static inline __m256 density_term8(__m256 r2, __m256 inv_h2)
{
    const __m256 q = _mm256_max_ps(_mm256_sub_ps(_mm256_set1_ps(1.0f), _mm256_mul_ps(r2, inv_h2)), _mm256_setzero_ps());
    return _mm256_mul_ps(_mm256_mul_ps(q, q), q);
}

/* ((t0+t1)+(t2+t3))+((t4+t5)+(t6+t7)) of the lanes of t. */
static inline float tree_sum8(__m256 t)
{
    const __m256 h = _mm256_hadd_ps(_mm256_hadd_ps(t, t), t); /* lane 0: (t0+t1)+(t2+t3); lane 4: (t4+t5)+(t6+t7) */
    return _mm_cvtss_f32(_mm_add_ss(_mm256_castps256_ps128(h), _mm256_extractf128_ps(h, 1)));
}
#endif

/* 1 + the kernel sum over r2[0, m): blocks of 8 (missing terms +0) summed as the tree
 * ((t0+t1)+(t2+t3))+((t4+t5)+(t6+t7)), blocks added in order -- the order of every density
 * path. r2 has 8 readable entries past m. */
static inline float density_sum(const sim_cpu_sph *s, const float *r2, size_t m, float inv_h2)
{
    (void)s; /* only the AVX2 path asks it which kernels to use */
    float rho = 1.0f;
    size_t k0 = 0;
#ifdef __AVX2__
    const __m256 vinv = _mm256_set1_ps(inv_h2);
    const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    for (; !s->portable && k0 < m; k0 += 8) {
        const __m256 live = _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32((int)(m - k0)), lanes));
        rho += tree_sum8(_mm256_and_ps(density_term8(_mm256_loadu_ps(r2 + k0), vinv), live));
    }
#endif
    for (; k0 < m; k0 += 8) {
        float t[8];
        for (size_t l = 0; l < 8; l++) t[l] = k0 + l < m ? density_term(r2[k0 + l], inv_h2) : 0.0f;
        rho += ((t[0] + t[1]) + (t[2] + t[3])) + ((t[4] + t[5]) + (t[6] + t[7]));
    }
    return rho;
}

/* Keeps the k nearest of the m candidates (r2s[], idx[]) by (r2, slot), in place; keys is
 * scratch of m entries. Returns min(m, k). */
static size_t keep_nearest(float *r2s, uint32_t *idx, size_t m, size_t k, uint64_t *keys)
{
    if (m <= k) return m;
    for (size_t j = 0; j < m; j++) { /* key (r2 bits, slot) orders like (r2, slot) */
        uint32_t bits;
        memcpy(&bits, &r2s[j], sizeof bits);
        keys[j] = (uint64_t)bits << 32 | idx[j];
    }
    select_smallest(keys, m, k);
    for (size_t j = 0; j < k; j++) {
        uint32_t bits = (uint32_t)(keys[j] >> 32);
        memcpy(&r2s[j], &bits, sizeof bits);
        idx[j] = (uint32_t)keys[j];
    }
    return k;
}

/* Particle i's density rho (1 + its kernel sum) and, with ctx->pressure, its pressure. */
static inline void store_density(const sph_ctx *ctx, size_t i, float rho)
{
    sim_cpu_sph *s = &ctx->c->sph;
    s->sp[4 * i + 3] = rho;
    if (ctx->pressure) s->sv[4 * i + 3] = MAX0(rho * ctx->c->step.inv_rho0 - 1.0f);
}

/* Neighbour search for every particle of the cells in this worker's range: its list, the
 * neighbour_cap nearest particles of other strands within the skin radius (1 + SPH_SKIN) h,
 * in slot order while they fit, and its density (store_density) from the kept candidates'
 * distances, which are those density_job measures, in the list's order: the same bits, without
 * a density pass over the lists just built. */
static void search_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu *c = ctx->c;
    sim_cpu_sph *s = &c->sph;
    const float hs = c->step.sph_h * (1.0f + SPH_SKIN), hs2 = hs * hs;
    const float inv_h2 = 1.0f / (c->step.sph_h * c->step.sph_h);
    const size_t cap = (size_t)c->params.neighbor_cap;
    size_t b, e;
    sim_pool_range(s->ncells, tid, nt, 1, &b, &e);
    uint64_t keys[SPH_MAX_CANDIDATES + SPH_PAD];
    float r2s[SPH_MAX_CANDIDATES + SPH_PAD];
    uint32_t idx[SPH_MAX_CANDIDATES + SPH_PAD];
    /* The neighbour ranges of the last corner seen with each parity of (cx, cy, cz): the particles
     * of a cell take one of its 8 corners (the halves they lie in), in no order. */
    uint32_t ccorner[8][3], rlo[8][8], rhi[8][8];
    int nr[8];
    for (int k = 0; k < 8; k++) ccorner[k][0] = UINT32_MAX;
    for (size_t bucket = b; bucket < e; bucket++) {
        uint32_t first = s->cell_start[bucket], last = s->cell_start[bucket + 1];
        for (uint32_t i = first; i < last; i++) {
            const float xi = s->sx[i], yi = s->sy[i], zi = s->sz[i];
            const uint32_t si = s->strand[i];
            uint32_t cx = lower_cell(xi, s->origin[0], s->inv_cell), cy = lower_cell(yi, s->origin[1], s->inv_cell),
                     cz = lower_cell(zi, s->origin[2], s->inv_cell);
            const int k = (int)((cx & 1) | (cy & 1) << 1 | (cz & 1) << 2);
            if (cx != ccorner[k][0] || cy != ccorner[k][1] || cz != ccorner[k][2]) {
                ccorner[k][0] = cx, ccorner[k][1] = cy, ccorner[k][2] = cz;
                nr[k] = neighbour_ranges(s, cx, cy, cz, rlo[k], rhi[k]);
            }
            size_t m = 0;
            for (int r = 0; r < nr[k]; r++) {
                const uint32_t rb = s->cell_start[rlo[k][r]], re = s->cell_start[rhi[k][r] + 1];
                m = scan_run(s, rb, re, xi, yi, zi, hs2, si, r2s, idx, m);
            }
            m = keep_nearest(r2s, idx, m, cap, keys);
            memcpy(s->nbr + (size_t)i * cap, idx, m * sizeof *idx);
            s->nnbr[i] = (uint8_t)m;
            store_density(ctx, i, density_sum(s, r2s, m, inv_h2));
        }
    }
}

/* Software prefetch in the passes over the lists (a sorted slot's row, then its neighbours'
 * records): the rows are read in slot order but each one's neighbours are scattered, and the
 * loads of a particle's neighbours wait on its row. Rows ROW_AHEAD particles ahead are fetched,
 * and the records (sp, and sv with vel) of the neighbours of the particle NBR_AHEAD ahead
 * (16 and 4 took 0.96-0.99x the CPU time of 8 and 2 at 16,384 x 64; 24 and 8 no clearer gain).
 * Always inlined: GCC takes a function that only prefetches for a pure one and drops its calls. */
#define SPH_ROW_AHEAD 16
#define SPH_NBR_AHEAD 4

__attribute__((always_inline)) static inline void prefetch_ahead(const sim_cpu_sph *s, size_t i, size_t e, size_t cap, bool vel)
{
    if (i + SPH_ROW_AHEAD < e) {
        const char *row = (const char *)(s->nbr + (i + SPH_ROW_AHEAD) * cap);
        __builtin_prefetch(row); /* the row's first, second and last lines (all of a row of up to 32) */
        __builtin_prefetch(row + 64);
        __builtin_prefetch(row + cap * sizeof *s->nbr - 1);
    }
    if (i + SPH_NBR_AHEAD < e) {
        const uint32_t *nb = s->nbr + (i + SPH_NBR_AHEAD) * cap;
        const int n = s->nnbr[i + SPH_NBR_AHEAD];
        for (int k = 0; k < n; k++) {
            __builtin_prefetch(s->sp + 4 * (size_t)nb[k]);
            if (vel) __builtin_prefetch(s->sv + 4 * (size_t)nb[k]);
        }
    }
}

/* The particle's unsorted records, SPH_SCATTER_AHEAD sorted slots ahead, for the passes that
 * read (pos, vel) or update (a) them by order: sorted neighbours are scattered in memory. */
#define SPH_SCATTER_AHEAD 16

__attribute__((always_inline)) static inline void prefetch_unsorted(const sim_cpu_sph *s, size_t slot, size_t e,
                                                                    float *const *arrays, int narrays, int write)
{
    if (slot + SPH_SCATTER_AHEAD < e) {
        const uint32_t o = s->order[slot + SPH_SCATTER_AHEAD];
        for (int k = 0; k < narrays; k++) __builtin_prefetch(arrays[k] + o, write);
    }
}

/* prefetch_unsorted of the held friction's record (c->af, one line a particle). */
__attribute__((always_inline)) static inline void prefetch_held(const sim_cpu *c, size_t slot, size_t e)
{
    if (slot + SPH_SCATTER_AHEAD < e) __builtin_prefetch(c->af + 4 * (size_t)c->sph.order[slot + SPH_SCATTER_AHEAD], 1);
}

/* The per-particle constants of the force pass. */
typedef struct force_consts {
    float inv_h, kp, mu_dt, inv_dt, keep, hold;
    int cap;
} force_consts;

/* The sums over a particle's neighbours: pressure acceleration (3), viscosity weight W, and
 * W-weighted neighbour velocity (3). Neighbours are taken in blocks of 8 (missing ones add
 * +0); a block's terms are summed as the tree ((t0+t1)+(t2+t3))+((t4+t5)+(t6+t7)) and the
 * blocks are added in order. The scalar and AVX2 paths follow this order exactly. */
enum { FORCE_TERMS = 7 };

/* e^x for the viscosity blend, written out so that the scalar and AVX2 paths give the same
 * bits: Cody-Waite reduction by ln 2, a degree-6 Taylor polynomial on |r| <= ln(2)/2 (relative
 * error below 3e-7), the power of two put into the exponent. x is clamped to [-87, 88]; NaN
 * gives e^-87. */
#define SPH_EXP_LO (-87.0f)
#define SPH_EXP_HI 88.0f
#define SPH_LOG2E 1.44269504f
#define SPH_LN2_HI 0.693359375f
#define SPH_LN2_LO (-2.12194440e-4f)
static inline float sph_exp(float x)
{
    x = x > SPH_EXP_LO ? x : SPH_EXP_LO;
    x = x < SPH_EXP_HI ? x : SPH_EXP_HI;
    const float n = floorf(x * SPH_LOG2E + 0.5f);
    const float r = (x - n * SPH_LN2_HI) - n * SPH_LN2_LO;
    const float p =
        1.0f + r * (1.0f + r * (0.5f + r * (1.0f / 6.0f + r * (1.0f / 24.0f + r * (1.0f / 120.0f + r * (1.0f / 720.0f))))));
    const uint32_t bits = (uint32_t)((int32_t)n + 127) << 23;
    float scale;
    memcpy(&scale, &bits, sizeof scale);
    return p * scale;
}

/* The low-pass of the SPH acceleration (sim_limits.h SIM_SPH_SMOOTH_TIME): this step's a moved
 * toward by 1 - keep from the previous step's prev. */
static inline float smooth_accel(float a, float prev, float keep) { return a + keep * (prev - a); }

/* Hair-hair static friction of particle i (unsorted index o), neighbour weight W and
 * neighbours' weighted mean motion vb: the held acceleration af grows by
 * SIM_HAIR_FRICTION_GAIN (sim_limits.h) of i's motion relative to vb per step, against it, and is
 * capped at hold x the pressure's push kp / rho_i x P_i x W (Coulomb: static below, slipping at
 * the cap; a non-finite one is dropped, so a NaN does not stay held). out = the new af, which
 * force_store keeps and adds to the acceleration. */
static void hold_accel(sim_cpu *c, const force_consts *fc, size_t i, uint32_t o, float W, float vbx, float vby,
                       float vbz, float out[3])
{
    const sim_cpu_sph *s = &c->sph;
    const float *vi = s->sv + 4 * i;
    const float g = (float)SIM_HAIR_FRICTION_GAIN * fc->inv_dt;
    const float *af = c->af + 4 * (size_t)o;
    float hx = af[0] - g * (vi[0] - vbx), hy = af[1] - g * (vi[1] - vby), hz = af[2] - g * (vi[2] - vbz);
    const float lim = fc->hold * fc->kp / s->sp[4 * i + 3] * vi[3] * W;
    const float l = sqrtf((hx * hx + hy * hy) + hz * hz);
    const bool held = l <= lim, slips = l > lim; /* both false when either is NaN */
    const float k = slips ? lim / l : 1.0f;
    out[0] = held || slips ? hx * k : 0.0f;
    out[1] = held || slips ? hy * k : 0.0f;
    out[2] = held || slips ? hz * k : 0.0f;
}

/* Stores particle i's acceleration acc (pressure and viscosity) at its unsorted index o: smoothed
 * with the one stored there less the held friction it included, then the new held friction
 * hold[3] (stored in c->af) added. */
static void force_store(sim_cpu *c, const force_consts *fc, uint32_t o, const float acc[3], const float hold[3])
{
    float *af = c->af + 4 * (size_t)o;
    for (int k = 0; k < 3; k++) {
        c->a[k][o] = smooth_accel(acc[k], c->a[k][o] - af[k], fc->keep) + hold[k];
        af[k] = hold[k];
    }
}

/* Turns the sums over particle i's neighbours into its acceleration, smoothed with the one at
 * its unsorted index, where it is stored, with the hair-hair friction (hold_accel). */
static void force_finish(sim_cpu *c, const force_consts *fc, size_t i, const float sum[FORCE_TERMS])
{
    const sim_cpu_sph *s = &c->sph;
    const float *vi = s->sv + 4 * i;
    const float W = sum[3];
    float ax = 0.0f, ay = 0.0f, az = 0.0f;
    float hold[3] = { 0.0f, 0.0f, 0.0f };
    const uint32_t o = s->order[i];
    if (W > 0.0f) {
        hold_accel(c, fc, i, o, W, sum[4] / W, sum[5] / W, sum[6] / W, hold);
        float kr = fc->kp / s->sp[4 * i + 3];
        ax = sum[0] * kr, ay = sum[1] * kr, az = sum[2] * kr;
        /* viscosity (Mueller et al. 2003) as an acceleration: mu / rho_i sum_j w_ij (v_j - v_i) =
         * mu (W / rho_i) (vbar - v_i), integrated exactly over the step (vbar held) */
        float blend = (1.0f - sph_exp(-fc->mu_dt * W / s->sp[4 * i + 3])) * fc->inv_dt;
        ax += blend * (sum[4] / W - vi[0]);
        ay += blend * (sum[5] / W - vi[1]);
        az += blend * (sum[6] / W - vi[2]);
    }
    const float acc[3] = { ax, ay, az };
    force_store(c, fc, o, acc, hold);
}

/* Pressure and viscosity of particle i from its neighbour list (scalar path). */
static void force_one(sim_cpu *c, const force_consts *fc, size_t i)
{
    const sim_cpu_sph *s = &c->sph;
    const float *pi = s->sp + 4 * i;
    const float Pi = s->sv[4 * i + 3];
    const uint32_t *nb = s->nbr + i * (size_t)fc->cap;
    const int n = s->nnbr[i];
    float sum[FORCE_TERMS] = { 0.0f };
    for (int k0 = 0; k0 < n; k0 += 8) {
        float t[FORCE_TERMS][8];
        for (int l = 0; l < 8; l++) {
            const bool live = k0 + l < n;
            const float *pj = s->sp + 4 * (size_t)(live ? nb[k0 + l] : 0);
            const float *vj = s->sv + 4 * (size_t)(live ? nb[k0 + l] : 0);
            float dx = pi[0] - pj[0], dy = pi[1] - pj[1], dz = pi[2] - pj[2];
            float r = sqrtf((dx * dx + dy * dy) + dz * dz);
            float q = MAX0(1.0f - r * fc->inv_h); /* a kept neighbour may have moved beyond h */
            float inv_rhoj = 1.0f / pj[3];
            float f = (Pi + vj[3]) * 0.5f * inv_rhoj * q * q / r;
            const bool pair = live && r > 1e-9f;
            float w = q * inv_rhoj;
            t[0][l] = pair ? f * dx : 0.0f;
            t[1][l] = pair ? f * dy : 0.0f;
            t[2][l] = pair ? f * dz : 0.0f;
            t[3][l] = live ? w : 0.0f;
            t[4][l] = live ? w * vj[0] : 0.0f;
            t[5][l] = live ? w * vj[1] : 0.0f;
            t[6][l] = live ? w * vj[2] : 0.0f;
        }
        for (int m = 0; m < FORCE_TERMS; m++)
            sum[m] += ((t[m][0] + t[m][1]) + (t[m][2] + t[m][3])) + ((t[m][4] + t[m][5]) + (t[m][6] + t[m][7]));
    }
    force_finish(c, fc, i, sum);
}

#ifdef __AVX2__
/* The float4 records a[4 j[0..7]] as four vectors of x, y, z and w (lane l = record j[l]). */
static inline void transpose8(const float *a, const uint32_t j[8], __m256 *x, __m256 *y, __m256 *z, __m256 *w)
{
    const __m256 r0 = _mm256_set_m128(_mm_loadu_ps(a + 4 * (size_t)j[4]), _mm_loadu_ps(a + 4 * (size_t)j[0]));
    const __m256 r1 = _mm256_set_m128(_mm_loadu_ps(a + 4 * (size_t)j[5]), _mm_loadu_ps(a + 4 * (size_t)j[1]));
    const __m256 r2 = _mm256_set_m128(_mm_loadu_ps(a + 4 * (size_t)j[6]), _mm_loadu_ps(a + 4 * (size_t)j[2]));
    const __m256 r3 = _mm256_set_m128(_mm_loadu_ps(a + 4 * (size_t)j[7]), _mm_loadu_ps(a + 4 * (size_t)j[3]));
    const __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpackhi_ps(r0, r1);
    const __m256 t2 = _mm256_unpacklo_ps(r2, r3), t3 = _mm256_unpackhi_ps(r2, r3);
    *x = _mm256_shuffle_ps(t0, t2, 0x44);
    *y = _mm256_shuffle_ps(t0, t2, 0xee);
    *z = _mm256_shuffle_ps(t1, t3, 0x44);
    *w = _mm256_shuffle_ps(t1, t3, 0xee);
}

/* Lane m of the result is ((a0+a1)+(a2+a3))+((a4+a5)+(a6+a7)) of the m-th input vector. */
static inline __m256 tree_sums8(__m256 a, __m256 b, __m256 c, __m256 d, __m256 e, __m256 f, __m256 g, __m256 h)
{
    const __m256 abcd = _mm256_hadd_ps(_mm256_hadd_ps(a, b), _mm256_hadd_ps(c, d));
    const __m256 efgh = _mm256_hadd_ps(_mm256_hadd_ps(e, f), _mm256_hadd_ps(g, h));
    return _mm256_add_ps(_mm256_permute2f128_ps(abcd, efgh, 0x20), _mm256_permute2f128_ps(abcd, efgh, 0x31));
}

/* The sums of force_one with the 8 neighbours of a block in the lanes of AVX2 vectors; lane m
 * of the result is sum[m] (lane 7 is 0). */
static __m256 force_sums_vec(const sim_cpu *c, const force_consts *fc, size_t i)
{
    const sim_cpu_sph *s = &c->sph;
    const float *pi = s->sp + 4 * i;
    const __m256 pix = _mm256_set1_ps(pi[0]), piy = _mm256_set1_ps(pi[1]), piz = _mm256_set1_ps(pi[2]);
    const __m256 Pi = _mm256_set1_ps(s->sv[4 * i + 3]);
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f), half = _mm256_set1_ps(0.5f);
    const __m256 inv_h = _mm256_set1_ps(fc->inv_h), tiny = _mm256_set1_ps(1e-9f);
    const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const uint32_t *nb = s->nbr + i * (size_t)fc->cap;
    const int n = s->nnbr[i];
    __m256 sum = zero;
    for (int k0 = 0; k0 < n; k0 += 8) {
        const __m256i livei = _mm256_cmpgt_epi32(_mm256_set1_epi32(n - k0), lanes);
        const __m256 live = _mm256_castsi256_ps(livei);
        /* the list rows are padded: lanes past the count read slot 0 and are masked out */
        uint32_t j[8];
        _mm256_storeu_si256((__m256i *)j, _mm256_and_si256(_mm256_loadu_si256((const __m256i *)(nb + k0)), livei));
        __m256 pjx, pjy, pjz, rhoj, vjx, vjy, vjz, Pj;
        transpose8(s->sp, j, &pjx, &pjy, &pjz, &rhoj);
        const __m256 inv_rhoj = _mm256_div_ps(one, rhoj);
        transpose8(s->sv, j, &vjx, &vjy, &vjz, &Pj);
        const __m256 dx = _mm256_sub_ps(pix, pjx), dy = _mm256_sub_ps(piy, pjy), dz = _mm256_sub_ps(piz, pjz);
        const __m256 r = _mm256_sqrt_ps(
            _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz)));
        /* max(x, 0) returns 0 for NaN and for -0, like MAX0 */
        const __m256 q = _mm256_max_ps(_mm256_sub_ps(one, _mm256_mul_ps(r, inv_h)), zero);
        __m256 f = _mm256_mul_ps(_mm256_mul_ps(_mm256_add_ps(Pi, Pj), half), inv_rhoj);
        f = _mm256_div_ps(_mm256_mul_ps(_mm256_mul_ps(f, q), q), r);
        const __m256 pair = _mm256_and_ps(live, _mm256_cmp_ps(r, tiny, _CMP_GT_OQ));
        const __m256 w = _mm256_mul_ps(q, inv_rhoj);
        sum = _mm256_add_ps(sum, tree_sums8(_mm256_and_ps(_mm256_mul_ps(f, dx), pair),
                                            _mm256_and_ps(_mm256_mul_ps(f, dy), pair),
                                            _mm256_and_ps(_mm256_mul_ps(f, dz), pair), _mm256_and_ps(w, live),
                                            _mm256_and_ps(_mm256_mul_ps(w, vjx), live),
                                            _mm256_and_ps(_mm256_mul_ps(w, vjy), live),
                                            _mm256_and_ps(_mm256_mul_ps(w, vjz), live), zero));
    }
    return sum;
}

static inline __m256 sph_exp8(__m256 x)
{
    x = _mm256_max_ps(x, _mm256_set1_ps(SPH_EXP_LO)); /* NaN -> the second operand, like sph_exp */
    x = _mm256_min_ps(x, _mm256_set1_ps(SPH_EXP_HI));
    const __m256 n = _mm256_floor_ps(_mm256_add_ps(_mm256_mul_ps(x, _mm256_set1_ps(SPH_LOG2E)), _mm256_set1_ps(0.5f)));
    const __m256 r = _mm256_sub_ps(_mm256_sub_ps(x, _mm256_mul_ps(n, _mm256_set1_ps(SPH_LN2_HI))),
                                   _mm256_mul_ps(n, _mm256_set1_ps(SPH_LN2_LO)));
    __m256 p = _mm256_add_ps(_mm256_set1_ps(1.0f / 120.0f), _mm256_mul_ps(r, _mm256_set1_ps(1.0f / 720.0f)));
    p = _mm256_add_ps(_mm256_set1_ps(1.0f / 24.0f), _mm256_mul_ps(r, p));
    p = _mm256_add_ps(_mm256_set1_ps(1.0f / 6.0f), _mm256_mul_ps(r, p));
    p = _mm256_add_ps(_mm256_set1_ps(0.5f), _mm256_mul_ps(r, p));
    p = _mm256_add_ps(_mm256_set1_ps(1.0f), _mm256_mul_ps(r, p));
    p = _mm256_add_ps(_mm256_set1_ps(1.0f), _mm256_mul_ps(r, p));
    const __m256i bits = _mm256_slli_epi32(_mm256_add_epi32(_mm256_cvttps_epi32(n), _mm256_set1_epi32(127)), 23);
    return _mm256_mul_ps(p, _mm256_castsi256_ps(bits));
}

/* hold_accel for the particles i0..i0+7, one per lane (unsorted indices o[8]): velocity v,
 * neighbours' weighted mean motion vb, density rho; lanes outside has (no neighbour weight W)
 * hold none. The same operations in the same order as hold_accel, so the same bits. out = the
 * new af of each lane. */
static void hold_accel8(const sim_cpu *c, const force_consts *fc, size_t i0, const uint32_t o[8], __m256 W,
                        const __m256 v[3], const __m256 vb[3], __m256 rho, __m256 has, float out[3][8])
{
    float prev[3][8];
    for (int k = 0; k < 3; k++)
        for (int l = 0; l < 8; l++) prev[k][l] = c->af[4 * (size_t)o[l] + (size_t)k];
    const __m256 P = _mm256_i32gather_ps(c->sph.sv + 4 * i0 + 3, _mm256_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28), 4);
    const __m256 g = _mm256_set1_ps((float)SIM_HAIR_FRICTION_GAIN * fc->inv_dt);
    __m256 h[3];
    for (int k = 0; k < 3; k++)
        h[k] = _mm256_sub_ps(_mm256_loadu_ps(prev[k]), _mm256_mul_ps(g, _mm256_sub_ps(v[k], vb[k])));
    const __m256 lim = _mm256_mul_ps(_mm256_mul_ps(_mm256_div_ps(_mm256_set1_ps(fc->hold * fc->kp), rho), P), W);
    const __m256 l = _mm256_sqrt_ps(
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(h[0], h[0]), _mm256_mul_ps(h[1], h[1])), _mm256_mul_ps(h[2], h[2])));
    const __m256 held = _mm256_cmp_ps(l, lim, _CMP_LE_OQ), slips = _mm256_cmp_ps(l, lim, _CMP_GT_OQ);
    const __m256 scale = _mm256_blendv_ps(_mm256_set1_ps(1.0f), _mm256_div_ps(lim, l), slips);
    const __m256 keep = _mm256_and_ps(_mm256_or_ps(held, slips), has);
    for (int k = 0; k < 3; k++) _mm256_storeu_ps(out[k], _mm256_and_ps(_mm256_mul_ps(h[k], scale), keep));
}

/* force_finish for particles i0..i0+7, one per lane; rows[l] = the sums of particle i0 + l. The
 * smoothing is scalar, as in force_finish, so both paths give the same bits. */
static void force_finish8(sim_cpu *c, const force_consts *fc, size_t i0, const __m256 rows[8])
{
    const sim_cpu_sph *s = &c->sph;
    /* 8x8 transpose: col[m] lane l = rows[l] lane m */
    __m256 t[8], u[8], col[8];
    for (int k = 0; k < 8; k += 2) {
        t[k] = _mm256_unpacklo_ps(rows[k], rows[k + 1]);
        t[k + 1] = _mm256_unpackhi_ps(rows[k], rows[k + 1]);
    }
    for (int k = 0; k < 8; k += 4) {
        u[k] = _mm256_shuffle_ps(t[k], t[k + 2], 0x44);
        u[k + 1] = _mm256_shuffle_ps(t[k], t[k + 2], 0xee);
        u[k + 2] = _mm256_shuffle_ps(t[k + 1], t[k + 3], 0x44);
        u[k + 3] = _mm256_shuffle_ps(t[k + 1], t[k + 3], 0xee);
    }
    for (int k = 0; k < 4; k++) {
        col[k] = _mm256_permute2f128_ps(u[k], u[k + 4], 0x20);
        col[k + 4] = _mm256_permute2f128_ps(u[k], u[k + 4], 0x31);
    }
    const __m256i row4 = _mm256_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28);
    const __m256 rho = _mm256_i32gather_ps(s->sp + 4 * i0 + 3, row4, 4);
    const __m256 vx = _mm256_i32gather_ps(s->sv + 4 * i0, row4, 4), vy = _mm256_i32gather_ps(s->sv + 4 * i0 + 1, row4, 4),
                 vz = _mm256_i32gather_ps(s->sv + 4 * i0 + 2, row4, 4);
    const __m256 W = col[3], one = _mm256_set1_ps(1.0f);
    const __m256 kr = _mm256_div_ps(_mm256_set1_ps(fc->kp), rho);
    const __m256 arg = _mm256_div_ps(_mm256_mul_ps(_mm256_set1_ps(-fc->mu_dt), W), rho);
    const __m256 blend = _mm256_mul_ps(_mm256_sub_ps(one, sph_exp8(arg)), _mm256_set1_ps(fc->inv_dt));
    const __m256 ax = _mm256_add_ps(_mm256_mul_ps(col[0], kr), _mm256_mul_ps(blend, _mm256_sub_ps(_mm256_div_ps(col[4], W), vx)));
    const __m256 ay = _mm256_add_ps(_mm256_mul_ps(col[1], kr), _mm256_mul_ps(blend, _mm256_sub_ps(_mm256_div_ps(col[5], W), vy)));
    const __m256 az = _mm256_add_ps(_mm256_mul_ps(col[2], kr), _mm256_mul_ps(blend, _mm256_sub_ps(_mm256_div_ps(col[6], W), vz)));
    const __m256 has = _mm256_cmp_ps(W, _mm256_setzero_ps(), _CMP_GT_OQ); /* no neighbour weight: no acceleration */
    const uint32_t *o = s->order + i0;
    const __m256 v[3] = { vx, vy, vz }, vb[3] = { _mm256_div_ps(col[4], W), _mm256_div_ps(col[5], W), _mm256_div_ps(col[6], W) };
    float out[3][8], hold[3][8];
    _mm256_storeu_ps(out[0], _mm256_and_ps(ax, has));
    _mm256_storeu_ps(out[1], _mm256_and_ps(ay, has));
    _mm256_storeu_ps(out[2], _mm256_and_ps(az, has));
    hold_accel8(c, fc, i0, o, W, v, vb, rho, has, hold);
    for (int l = 0; l < 8; l++) {
        const float acc[3] = { out[0][l], out[1][l], out[2][l] }, held[3] = { hold[0][l], hold[1][l], hold[2][l] };
        force_store(c, fc, o[l], acc, held);
    }
}
#endif

static void force_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu *c = ctx->c;
    const float h = c->step.sph_h;
    const force_consts fc = { 1.0f / h, c->step.kp, c->step.mu_dt, 1.0f / ctx->dt, c->step.sph_keep,
                              c->step.hair_friction, c->params.neighbor_cap };
    size_t b, e, i;
    sim_pool_range(c->n, tid, nt, 64, &b, &e);
    i = b;
#ifdef __AVX2__
    if (!c->sph.portable)
        for (; i + 8 <= e; i += 8) {
            __m256 rows[8];
            for (int l = 0; l < 8; l++) {
                prefetch_ahead(&c->sph, i + (size_t)l, e, (size_t)fc.cap, true);
                prefetch_unsorted(&c->sph, i + (size_t)l, e, c->a, 3, 1);
                prefetch_held(c, i + (size_t)l, e);
                rows[l] = force_sums_vec(c, &fc, i + (size_t)l);
            }
            force_finish8(c, &fc, i, rows);
        }
#endif
    for (; i < e; i++) {
        prefetch_ahead(&c->sph, i, e, (size_t)fc.cap, true);
        prefetch_unsorted(&c->sph, i, e, c->a, 3, 1);
        prefetch_held(c, i, e);
        force_one(c, &fc, i);
    }
}

/* The velocity component k of particle i for the viscosity: its motion since the last
 * evaluation (zero in the rest pass). */
static inline float motion(const sph_ctx *ctx, int k, uint32_t i)
{
    return ctx->prev ? (ctx->pos[k][i] - ctx->prev[k][i]) * ctx->inv_since : 0.0f;
}

/* Copies positions and velocities (motion) into the sorted slots given by order, and the
 * positions again into the SoA arrays the neighbour search scans. */
static void gather_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu *c = ctx->c;
    sim_cpu_sph *s = &c->sph;
    size_t b, e;
    sim_pool_range(c->n, tid, nt, 64, &b, &e);
    for (size_t slot = b; slot < e; slot++) {
        prefetch_unsorted(s, slot, e, ctx->pos, 3, 0);
        if (ctx->prev) prefetch_unsorted(s, slot, e, ctx->prev, 3, 0);
        const uint32_t i = s->order[slot];
        for (int k = 0; k < 3; k++) {
            s->sp[4 * slot + k] = ctx->pos[k][i];
            s->sv[4 * slot + k] = motion(ctx, k, i);
        }
        s->sx[slot] = ctx->pos[0][i], s->sy[slot] = ctx->pos[1][i], s->sz[slot] = ctx->pos[2][i];
    }
}

/* The offset d of the particle at (x, y, z) from its build position (bx, by, bz) carried by the
 * head's motion since the build; returns true when it is longer than ctx->stray2 allows, or not
 * finite. */
static inline bool offset_from(const sph_ctx *ctx, float x, float y, float z, float bx, float by, float bz, float d[3])
{
    const float *m = ctx->carry;
    d[0] = x - (m[0] * bx + m[1] * by + m[2] * bz + m[3]);
    d[1] = y - (m[4] * bx + m[5] * by + m[6] * bz + m[7]);
    d[2] = z - (m[8] * bx + m[9] * by + m[10] * bz + m[11]);
    return !((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2] <= ctx->stray2);
}

/* True when a strand's tip (the last level, which the head's motion swings the farthest) has
 * strayed (offset_from): a look at ns particles that spares the regather pass a rebuild's
 * lists would throw away. Its verdict implies regather_job's, so the lists are the same. */
static bool tips_strayed(const sph_ctx *ctx)
{
    const sim_cpu *c = ctx->c;
    const sim_cpu_sph *s = &c->sph;
    for (size_t i = c->n - c->ns; i < c->n; i++) {
        const uint32_t slot = s->slot_of[i];
        float d[3];
        if (offset_from(ctx, ctx->pos[0][i], ctx->pos[1][i], ctx->pos[2][i], s->sx[slot], s->sy[slot], s->sz[slot], d))
            return true;
    }
    return false;
}

/* Kept lists: refreshes the sorted copies from the current state (same slot order) and sets
 * ctx->strayed when a particle's offset from its carried build position is longer than
 * ctx->stray2 allows (or not finite), ctx->beyond when one is longer than ctx->half2. Once one has
 * strayed the lists are rebuilt and gathered anew, so every part stops at its next block of
 * SPH_STRAY_BLOCK slots. */
static void regather_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu *c = ctx->c;
    sim_cpu_sph *s = &c->sph;
    size_t b, e;
    sim_pool_range(c->n, tid, nt, 64, &b, &e);
    bool strayed = false, beyond = false;
    for (size_t slot = b; slot < e; slot++) {
        if ((slot - b) % SPH_STRAY_BLOCK == 0) {
            if (strayed) atomic_store_explicit(&ctx->strayed, true, memory_order_relaxed);
            if (strayed || atomic_load_explicit(&ctx->strayed, memory_order_relaxed)) return;
        }
        prefetch_unsorted(s, slot, e, ctx->pos, 3, 0);
        prefetch_unsorted(s, slot, e, ctx->prev, 3, 0);
        const uint32_t i = s->order[slot];
        const float x = ctx->pos[0][i], y = ctx->pos[1][i], z = ctx->pos[2][i];
        s->sp[4 * slot] = x, s->sp[4 * slot + 1] = y, s->sp[4 * slot + 2] = z;
        s->sv[4 * slot] = motion(ctx, 0, i), s->sv[4 * slot + 1] = motion(ctx, 1, i), s->sv[4 * slot + 2] = motion(ctx, 2, i);
        float d[3];
        strayed |= offset_from(ctx, x, y, z, s->sx[slot], s->sy[slot], s->sz[slot], d);
        beyond |= !((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2] <= ctx->half2);
    }
    if (strayed) atomic_store_explicit(&ctx->strayed, true, memory_order_relaxed);
    if (beyond) atomic_store_explicit(&ctx->beyond, true, memory_order_relaxed);
}

/* On an unfolded grid, after regather_job: each occupied cell's box of its particles' offsets from
 * their carried build positions and the largest squared offset (dbox), for the cells of this
 * worker's range of buckets. The offsets are measured again here, from the refreshed sorted
 * copies in cell order, rather than kept by the regather pass, which goes in slot parts that
 * split cells and runs at every kept pass, while this runs only past half the skin. */
static void box_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu_sph *s = &ctx->c->sph;
    size_t b, e;
    sim_pool_range(sim_cpu_sph_grid_cells(s), tid, nt, 1, &b, &e);
    for (size_t bucket = b; bucket < e; bucket++) {
        const uint32_t first = s->cell_start[bucket], last = s->cell_start[bucket + 1];
        if (first == last) continue;
        float lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY }, far2 = 0.0f;
        for (uint32_t slot = first; slot < last; slot++) {
            float d[3];
            offset_from(ctx, s->sp[4 * slot], s->sp[4 * slot + 1], s->sp[4 * slot + 2], s->sx[slot], s->sy[slot],
                        s->sz[slot], d);
            for (int k = 0; k < 3; k++) {
                lo[k] = d[k] < lo[k] ? d[k] : lo[k];
                hi[k] = d[k] > hi[k] ? d[k] : hi[k];
            }
            const float d2 = (d[0] * d[0] + d[1] * d[1]) + d[2] * d[2];
            far2 = d2 > far2 ? d2 : far2;
        }
        float *box = s->dbox + SPH_BOX * bucket;
        box[0] = lo[0], box[1] = lo[1], box[2] = lo[2], box[3] = hi[0], box[4] = hi[1], box[5] = hi[2];
        box[6] = far2;
    }
}

/* True when a particle of bucket a and one of bucket b (of other strands; each pair once when a
 * == b) that were farther apart than the skin radius at the build (so neither is in the other's
 * list, SPH_SKIN) are within h now (with a margin for the kernels' rounding). Counts the pairs
 * down from ctx->look_budget; true when it runs out. */
static bool cells_pair_close(sph_ctx *ctx, size_t a, size_t b)
{
    const sim_cpu *c = ctx->c;
    const sim_cpu_sph *s = &c->sph;
    const float hs = c->step.sph_h * (1.0f + SPH_SKIN), hs2 = hs * hs;
    const float near2 = c->step.sph_h * c->step.sph_h * 1.0001f;
    const uint32_t a0 = s->cell_start[a], a1 = s->cell_start[a + 1], b1 = s->cell_start[b + 1];
    const long pairs = (long)(a1 - a0) * (long)(b1 - s->cell_start[b]);
    if (atomic_fetch_sub_explicit(&ctx->look_budget, pairs, memory_order_relaxed) < pairs) return true;
    for (uint32_t i = a0; i < a1; i++) {
        for (uint32_t j = a == b ? i + 1 : s->cell_start[b]; j < b1; j++) {
            const float bx = s->sx[j] - s->sx[i], by = s->sy[j] - s->sy[i], bz = s->sz[j] - s->sz[i];
            const float dx = s->sp[4 * j] - s->sp[4 * i], dy = s->sp[4 * j + 1] - s->sp[4 * i + 1],
                        dz = s->sp[4 * j + 2] - s->sp[4 * i + 2];
            const bool was_far = !((bx * bx + by * by) + bz * bz < hs2), near = (dx * dx + dy * dy) + dz * dz < near2;
            if (was_far && near && s->strand[i] != s->strand[j]) return true;
        }
    }
    return false;
}

/* The relative check of kept lists on an unfolded grid, after box_job, for the cells of this
 * worker's range of buckets: sets ctx->strayed when a pair outside the lists may have come within
 * h. Two particles whose offsets are both within SPH_SKIN h / 2 are within SPH_SKIN h of each
 * other, so only a cell with a longer offset (a hot cell) is looked at, with each of its
 * neighbours and itself. Where the offsets of the particles of two neighbouring cells (or of one
 * cell) differ by at most SPH_SKIN h (dbox), no pair has come within h; where they may differ by
 * more (a few cells of tangled hair), their pairs are looked at one by one (cells_pair_close), up
 * to SPH_LOOK_BUDGET n pairs in all. Two hot cells are looked at once, from the lower index. */
static void cells_check_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu *c = ctx->c;
    const sim_cpu_sph *s = &c->sph;
    const float skin = SPH_SKIN * c->step.sph_h, lim2 = skin * skin;
    const size_t cells = sim_cpu_sph_grid_cells(s);
    int64_t off[27];
    int noff = 0;
    for (int64_t dz = -1; dz <= 1; dz++)
        for (int64_t dy = -1; dy <= 1; dy++)
            for (int64_t dx = -1; dx <= 1; dx++) off[noff++] = (dz * (int64_t)s->dims[1] + dy) * (int64_t)s->dims[0] + dx;
    size_t b, e;
    sim_pool_range(cells, tid, nt, 1, &b, &e);
    for (size_t bucket = b; bucket < e; bucket++) {
        if (s->cell_start[bucket] == s->cell_start[bucket + 1]) continue;
        const float *A = s->dbox + SPH_BOX * bucket;
        if (!(A[6] > ctx->half2)) continue; /* a cool cell */
        if (atomic_load_explicit(&ctx->strayed, memory_order_relaxed)) return;
        for (int k = 0; k < noff; k++) {
            /* cells at the grid's edge (a non-finite particle's, clamped to 0) may reach past it */
            const int64_t nbk = (int64_t)bucket + off[k];
            if (nbk < 0 || nbk >= (int64_t)cells || s->cell_start[nbk] == s->cell_start[nbk + 1]) continue;
            const float *B = s->dbox + SPH_BOX * (size_t)nbk;
            if (nbk < (int64_t)bucket && B[6] > ctx->half2) continue; /* two hot cells: looked at from nbk */
            float w2 = 0.0f;
            for (int a = 0; a < 3; a++) {
                const float u = A[3 + a] - B[a], v = B[3 + a] - A[a], w = u > v ? u : v;
                w2 += w * w;
            }
            if (!(w2 <= lim2) && cells_pair_close(ctx, bucket, (size_t)nbk)) {
                atomic_store_explicit(&ctx->strayed, true, memory_order_relaxed);
                return;
            }
        }
    }
}

/* Density over the listed neighbours at their current distances (those beyond h add 0) for
 * every particle in this worker's range and, with ctx->pressure, its pressure. */
static void density_job(void *vctx, int tid, int nt)
{
    sph_ctx *ctx = vctx;
    sim_cpu *c = ctx->c;
    sim_cpu_sph *s = &c->sph;
    const float inv_h2 = 1.0f / (c->step.sph_h * c->step.sph_h);
    const int cap = c->params.neighbor_cap;
    size_t b, e;
    sim_pool_range(c->n, tid, nt, 64, &b, &e);
    for (size_t i = b; i < e; i++) {
        prefetch_ahead(s, i, e, (size_t)cap, false);
        const float *pi = s->sp + 4 * i;
        const uint32_t *nb = s->nbr + i * (size_t)cap;
        const int n = s->nnbr[i];
        float r2[SIM_MAX_NEIGHBOR_CAP + SPH_PAD];
        int k = 0;
#ifdef __AVX2__
        const __m256 pix = _mm256_set1_ps(pi[0]), piy = _mm256_set1_ps(pi[1]), piz = _mm256_set1_ps(pi[2]);
        const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        for (; !s->portable && k < n; k += 8) { /* rows are padded; lanes past n read slot 0 */
            const __m256i live = _mm256_cmpgt_epi32(_mm256_set1_epi32(n - k), lanes);
            uint32_t j[8];
            _mm256_storeu_si256((__m256i *)j, _mm256_and_si256(_mm256_loadu_si256((const __m256i *)(nb + k)), live));
            __m256 pjx, pjy, pjz, pjw;
            transpose8(s->sp, j, &pjx, &pjy, &pjz, &pjw);
            const __m256 dx = _mm256_sub_ps(pjx, pix), dy = _mm256_sub_ps(pjy, piy), dz = _mm256_sub_ps(pjz, piz);
            _mm256_storeu_ps(r2 + k, _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                                                   _mm256_mul_ps(dz, dz)));
        }
#endif
        for (; k < n; k++) {
            const float *pj = s->sp + 4 * (size_t)nb[k];
            float dx = pj[0] - pi[0], dy = pj[1] - pi[1], dz = pj[2] - pi[2];
            r2[k] = (dx * dx + dy * dy) + dz * dz;
        }
        store_density(ctx, i, density_sum(s, r2, (size_t)n, inv_h2));
    }
}

/* The rows (m0 m1 m2 t) of the rigid motion from head a to head b: p -> Rb Ra^T (p - ta) + tb. */
static void head_motion(core_xform a, core_xform b, float out[12])
{
    const core_quat q = core_q_mul(b.rot, core_q_conj(a.rot));
    const core_vec3 col[3] = { core_q_rotate(q, core_v3(1, 0, 0)), core_q_rotate(q, core_v3(0, 1, 0)),
                               core_q_rotate(q, core_v3(0, 0, 1)) };
    const core_vec3 t = core_v3_sub(b.pos, core_q_rotate(q, a.pos));
    const float tt[3] = { t.x, t.y, t.z };
    for (int r = 0; r < 3; r++) {
        out[4 * r] = (&col[0].x)[r], out[4 * r + 1] = (&col[1].x)[r], out[4 * r + 2] = (&col[2].x)[r];
        out[4 * r + 3] = tt[r];
    }
}

/* True when the skin lists of the last build still hold every pair within h (see SPH_SKIN): no
 * particle has strayed from its build position carried by the head's motion since (frame: the
 * head now), nor, on an unfolded grid, from those of the particles around it. Refreshes the
 * sorted copies when they do. */
static bool lists_hold(sph_ctx *ctx, core_xform frame)
{
    sim_cpu *c = ctx->c;
    const float half = 0.5f * SPH_SKIN * c->step.sph_h;
    const float bound = sim_cpu_sph_unfolded(&c->sph) ? SPH_REACH * c->step.sph_h : half;
    head_motion(c->sph.build_head, frame, ctx->carry);
    ctx->stray2 = bound * bound;
    ctx->half2 = half * half;
    if (tips_strayed(ctx)) return false;
    atomic_init(&ctx->strayed, false);
    atomic_init(&ctx->beyond, false);
    sim_pool_run_parts(&c->pool, regather_job, ctx, SPH_PARTS);
    if (atomic_load_explicit(&ctx->strayed, memory_order_relaxed)) return false;
    if (!atomic_load_explicit(&ctx->beyond, memory_order_relaxed)) return true; /* within half the skin */
    /* Past half the skin: the relative check each pass from now on, or a search that lets the
     * passes after it go unchecked. The check while it has cost less than a search: while fewer
     * passes than SPH_CHECK_WORTH x the cells' mean occupancy took the hair from the search to here,
     * and as many have run the check since. Counted in passes, so a pass taken again after an
     * abandoned one decides the same. */
    sim_cpu_sph *s = &c->sph;
    if (s->beyond_pass == UINT64_MAX) s->beyond_pass = s->pass_no;
    const double worth = SPH_CHECK_WORTH * (double)c->n / (double)(s->occupied ? s->occupied : 1);
    if ((double)(s->beyond_pass - s->search_pass) >= worth || (double)(s->pass_no - s->beyond_pass) >= worth)
        return false;
    sim_pool_run_parts(&c->pool, box_job, ctx, SPH_PARTS);
    atomic_init(&ctx->look_budget, (long)(SPH_LOOK_BUDGET * c->n));
    sim_pool_run_parts(&c->pool, cells_check_job, ctx, SPH_PARTS);
    return !atomic_load_explicit(&ctx->strayed, memory_order_relaxed);
}

/* Sorts the particles into the hash grid of cells of twice the skin radius and builds the
 * skin lists (the sorted copies are gathered on the way) and the densities (search_job). */
static core_status rebuild_lists(sph_ctx *ctx, core_err *err)
{
    sim_cpu *c = ctx->c;
    sim_cpu_sph *s = &c->sph;
    const int nt = c->pool.nthreads;
    sim_pool_run(&c->pool, bounds_job, ctx);
    float lo[3], hi[3];
    for (int k = 0; k < 3; k++) {
        lo[k] = ctx->bmin[0][k], hi[k] = ctx->bmax[0][k];
        for (int t = 1; t < nt; t++) lo[k] = fminf(lo[k], ctx->bmin[t][k]), hi[k] = fmaxf(hi[k], ctx->bmax[t][k]);
        if (!isfinite(lo[k]) || !isfinite(hi[k])) lo[k] = hi[k] = 0.0f; /* non-finite strands are reset after */
    }
    /* cells of twice the skin radius hashed into a power-of-two table of at least 2n buckets;
     * the points within the skin radius of a particle lie in the 2x2x2 cells on its side of
     * its own cell */
    s->cell_size = 2.0f * c->step.sph_h * (1.0f + SPH_SKIN);
    s->inv_cell = 1.0f / s->cell_size;
    s->ncells = 4096;
    while (s->ncells < 2 * c->n) s->ncells *= 2;
    for (int k = 0; k < 3; k++) {
        s->origin[k] = lo[k] - s->cell_size; /* cell coords >= 1, so cx - 1 does not wrap */
        double cells = floor((double)(hi[k] - s->origin[k]) * s->inv_cell) + 2.0;
        s->dims[k] = cells < 1048576.0 ? (uint32_t)cells : 1048576u;
    }
    core_status st = sph_reserve(s, c->n, c->params.neighbor_cap, s->ncells, nt, err);
    if (st != CORE_OK) return st;
    sim_pool_run(&c->pool, count_job, ctx);
    sim_pool_run(&c->pool, scan_sum_job, ctx);
    sim_pool_run(&c->pool, scan_fill_job, ctx);
    s->occupied = 0;
    for (int t = 0; t < nt; t++) s->occupied += s->tocc[t];
    sim_pool_run(&c->pool, scatter_job, ctx);
    sim_pool_run_parts(&c->pool, gather_job, ctx, SPH_PARTS);
    sim_pool_run_parts(&c->pool, search_job, ctx, SPH_PARTS);
    return CORE_OK;
}

/* c's cancel poll between the SPH pass's parts, when the caller may abandon the step. */
static bool sph_cancelled(const sim_cpu *c, bool cancellable)
{
    return cancellable && c->cancel(c->cancel_ctx);
}

core_status sim_cpu_sph_pass(sim_cpu *c, float *const pos[3], float *const prev[3], float inv_since, float dt,
                             core_xform frame, double *out_mean_rho, bool cancellable, core_err *err)
{
    sph_ctx ctx = { .c = c, .pos = pos, .prev = prev, .inv_since = inv_since, .dt = dt, .pressure = out_mean_rho == NULL };
    sim_cpu_sph *s = &c->sph;
    const bool rebuild = !(s->lists_valid && prev && lists_hold(&ctx, frame));
    if (rebuild) {
        core_status st = rebuild_lists(&ctx, err);
        if (st != CORE_OK) return st;
        s->build_head = frame;
        s->lists_valid = out_mean_rho == NULL; /* lists of the rest pose are not reused */
        s->search_pass = s->pass_no;
        s->beyond_pass = UINT64_MAX;
    }
    if (sph_cancelled(c, cancellable)) return core_fail(err, CORE_ECANCELED, "step abandoned on request");
    if (!rebuild) sim_pool_run_parts(&c->pool, density_job, &ctx, SPH_PARTS); /* a rebuild's search set them */
    if (out_mean_rho) {
        double sum = 0.0; /* serial, in sorted order: the same bits for any thread count */
        for (size_t i = 0; i < c->n; i++) sum += s->sp[4 * i + 3];
        *out_mean_rho = sum / (double)c->n;
        return CORE_OK;
    }
    if (sph_cancelled(c, cancellable)) return core_fail(err, CORE_ECANCELED, "step abandoned on request");
    sim_pool_run_parts(&c->pool, force_job, &ctx, SPH_PARTS);
    s->pass_no++; /* counted once complete, so an abandoned pass taken again counts once */
    c->stats.sph_passes++;
    c->stats.sph_searches += rebuild;
    return CORE_OK;
}
