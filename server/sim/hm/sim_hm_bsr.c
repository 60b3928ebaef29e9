/* sim_hm: the implicit system as a block-sparse matrix (3x3 blocks over the mesh's fixed vertex
 * adjacency): its pattern from the condition rows, and its product. */
#include <stdlib.h>
#include <string.h>

#include "sim_hm_internal.h"

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* The block at v (SIM_HM_BLOCK floats) times the 3-vector at x; the result's 4th lane is
 * meaningless (each column is read as 4 floats, the next one's first with it: val's padding
 * covers the last block's). */
static inline sim_hm_v4 block_mul(const float *restrict v, const float *restrict x)
{
    sim_hm_v4 c0, c1, c2;
    memcpy(&c0, v, sizeof c0), memcpy(&c1, v + 3, sizeof c1), memcpy(&c2, v + 6, sizeof c2);
    return (c0 * x[0] + c1 * x[1]) + c2 * x[2];
}

static uint64_t key(uint32_t r, uint32_t c) { return ((uint64_t)r << 32) | c; }

/* The block (r, c), which the pattern holds. */
static uint32_t find(const sim_hm_bsr *m, uint32_t r, uint32_t c)
{
    uint32_t lo = m->row[r], hi = m->row[r + 1];
    while (hi - lo > 1) {
        const uint32_t mid = (lo + hi) / 2;
        if (m->col[mid] <= c) lo = mid;
        else hi = mid;
    }
    return lo;
}

core_status sim_hm_bsr_build(sim_hm *h, core_err *err)
{
    sim_hm_bsr *m = &h->bsr;
    sim_hm_rows *rw = &h->rows;
    memset(m, 0, sizeof *m);
    sim_hm_dampers *d = &h->damp;
    const size_t nk = (size_t)h->n + 12 * (size_t)rw->n + 2 * (size_t)d->n;
    uint64_t *k = malloc(nk * sizeof *k);
    m->row = malloc(((size_t)h->n + 1) * sizeof *m->row);
    m->diag = malloc((size_t)h->n * sizeof *m->diag);
    if (!k || !m->row || !m->diag) {
        free(k);
        return core_fail(err, CORE_ENOMEM, "out of memory for the hair-mesh system's pattern");
    }
    size_t n = 0;
    for (uint32_t i = 0; i < h->n; i++) k[n++] = key(i, i);
    for (uint32_t i = 0; i < d->n; i++) k[n++] = key(d->a[i], d->b[i]), k[n++] = key(d->b[i], d->a[i]);
    for (uint32_t i = 0; i < rw->n; i++)
        for (int a = 0; a < rw->nv[i]; a++)
            for (int b = 0; b < rw->nv[i]; b++)
                if (a != b) k[n++] = key(rw->v[4 * (size_t)i + a], rw->v[4 * (size_t)i + b]);
    qsort(k, n, sizeof *k, cmp_u64);
    size_t u = 0;
    for (size_t i = 0; i < n; i++)
        if (u == 0 || k[u - 1] != k[i]) k[u++] = k[i];
    m->n = h->n, m->nnz = (uint32_t)u;
    m->col = malloc(u * sizeof *m->col);
    m->val = calloc(SIM_HM_BLOCK * u + 3, sizeof *m->val);
    if (!m->col || !m->val) {
        free(k);
        return core_fail(err, CORE_ENOMEM, "out of memory for the hair-mesh system's blocks");
    }
    memset(m->row, 0, ((size_t)h->n + 1) * sizeof *m->row);
    for (size_t i = 0; i < u; i++) {
        m->col[i] = (uint32_t)(k[i] & 0xffffffffu);
        m->row[(k[i] >> 32) + 1]++;
    }
    free(k);
    for (uint32_t i = 0; i < h->n; i++) m->row[i + 1] += m->row[i];
    for (uint32_t i = 0; i < h->n; i++) m->diag[i] = find(m, i, i);
    for (uint32_t i = 0; i < d->n; i++) d->at[2 * i] = find(m, d->a[i], d->b[i]), d->at[2 * i + 1] = find(m, d->b[i], d->a[i]);
    for (uint32_t i = 0; i < rw->n; i++)
        for (int a = 0; a < 4; a++)
            for (int b = 0; b < 4; b++)
                rw->at[16 * (size_t)i + 4 * a + b] = find(m, rw->v[4 * (size_t)i + a], rw->v[4 * (size_t)i + b]);
    return CORE_OK;
}

void sim_hm_bsr_free(sim_hm_bsr *m)
{
    free(m->row), free(m->col), free(m->diag), free(m->val);
    memset(m, 0, sizeof *m);
}

/* The most vectors one pass takes (sim_hm_bsr_apply3, sim_hm_bsr_lower_solve3). */
#define NV_MAX 3

/* For each of the nv vectors x[v], the sum of blocks b .. e - 1 (one row's) times x[v]'s
 * 3-vectors, in two partial sums (even and odd blocks) so the additions do not wait on each
 * other: out[v]. Several vectors in one pass read each block once and interleave their chains
 * (each vector's sums the same as alone). */
static inline void rows_mul(const sim_hm_bsr *m, uint32_t b, uint32_t e, int nv, const float *const *x, sim_hm_v4 *out)
{
    sim_hm_v4 s0[NV_MAX] = { { 0 } }, s1[NV_MAX] = { { 0 } };
    for (; b + 2 <= e; b += 2) {
        const float *v0 = m->val + SIM_HM_BLOCK * (size_t)b, *v1 = v0 + SIM_HM_BLOCK;
        const size_t c0 = 3 * (size_t)m->col[b], c1 = 3 * (size_t)m->col[b + 1];
        for (int v = 0; v < nv; v++) s0[v] += block_mul(v0, x[v] + c0), s1[v] += block_mul(v1, x[v] + c1);
    }
    if (b < e)
        for (int v = 0; v < nv; v++) s0[v] += block_mul(m->val + SIM_HM_BLOCK * (size_t)b, x[v] + 3 * (size_t)m->col[b]);
    for (int v = 0; v < nv; v++) out[v] = s0[v] + s1[v];
}

static inline void store3(float *y, sim_hm_v4 a) { y[0] = a[0], y[1] = a[1], y[2] = a[2]; }

/* y[v] = A x[v] for nv vectors in one pass. */
static inline void apply_n(const sim_hm_bsr *m, int nv, const float *const *x, float *const *y)
{
    for (uint32_t i = 0; i < m->n; i++) {
        sim_hm_v4 s[NV_MAX];
        rows_mul(m, m->row[i], m->row[i + 1], nv, x, s);
        for (int v = 0; v < nv; v++) store3(y[v] + 3 * (size_t)i, s[v]);
    }
}

void sim_hm_bsr_apply(const sim_hm_bsr *m, const float *x, float *y) { apply_n(m, 1, &x, &y); }

void sim_hm_bsr_apply3(const sim_hm_bsr *m, const float *const x[3], float *const y[3]) { apply_n(m, 3, x, y); }

void sim_hm_bsr_row_apply(const sim_hm_bsr *m, uint32_t i, const float *x, float y[3])
{
    sim_hm_v4 s;
    rows_mul(m, m->row[i], m->row[i + 1], 1, &x, &s);
    store3(y, s);
}

/* The symmetric block p (xx yy zz xy xz yz) times a, as its columns times a's lanes (the same
 * sums in the same order per lane, in vector operations). */
static inline sim_hm_v4 sym_mul(const float *p, sim_hm_v4 a)
{
    const sim_hm_v4 c0 = { p[0], p[3], p[4], 0.0f }, c1 = { p[3], p[1], p[5], 0.0f }, c2 = { p[4], p[5], p[2], 0.0f };
    return (c0 * a[0] + c1 * a[1]) + c2 * a[2];
}

/* The forward sweep t[v] = (D + L)^-1 r[v] for nv vectors in one pass (t[v] may be r[v]). */
static inline void lower_n(const sim_hm_bsr *m, const float *dinv, const uint8_t *fixed, int nv, const float *const *r,
                           float *const *t)
{
    for (uint32_t i = 0; i < m->n; i++) {
        if (fixed[i]) {
            for (int v = 0; v < nv; v++) store3(t[v] + 3 * (size_t)i, (sim_hm_v4){ 0 });
            continue;
        }
        sim_hm_v4 s[NV_MAX];
        rows_mul(m, m->row[i], m->diag[i], nv, (const float *const *)t, s);
        for (int v = 0; v < nv; v++) {
            const float *ri = r[v] + 3 * (size_t)i;
            store3(t[v] + 3 * (size_t)i, sym_mul(dinv + 6 * (size_t)i, (sim_hm_v4){ ri[0], ri[1], ri[2], 0.0f } - s[v]));
        }
    }
}

void sim_hm_bsr_lower_solve(const sim_hm_bsr *m, const float *dinv, const uint8_t *fixed, const float *r, float *t)
{
    lower_n(m, dinv, fixed, 1, &r, &t);
}

void sim_hm_bsr_lower_solve3(const sim_hm_bsr *m, const float *dinv, const uint8_t *fixed, float *const t[3])
{
    lower_n(m, dinv, fixed, 3, (const float *const *)t, t);
}

void sim_hm_bsr_upper_solve(const sim_hm_bsr *m, const float *dinv, const uint8_t *fixed, const float *r, float *t,
                            float *u)
{
    for (uint32_t i = m->n; i-- > 0;) {
        float *ti = t + 3 * (size_t)i;
        sim_hm_v4 s = { 0 };
        if (!fixed[i]) {
            rows_mul(m, m->diag[i] + 1, m->row[i + 1], 1, (const float *const *)&t, &s);
            const float *ri = r + 3 * (size_t)i;
            store3(ti, sym_mul(dinv + 6 * (size_t)i, (sim_hm_v4){ ri[0], ri[1], ri[2], 0.0f } - s));
        } else {
            ti[0] = ti[1] = ti[2] = 0.0f;
        }
        if (u) store3(u + 3 * (size_t)i, s);
    }
}

void sim_hm_bsr_diag_apply(const sim_hm_bsr *m, const uint8_t *fixed, const float *restrict x, float *restrict y)
{
    for (uint32_t i = 0; i < m->n; i++) {
        float *yi = y + 3 * (size_t)i;
        if (fixed[i]) yi[0] = yi[1] = yi[2] = 0.0f;
        else store3(yi, block_mul(m->val + SIM_HM_BLOCK * (size_t)m->diag[i], x + 3 * (size_t)i));
    }
}
