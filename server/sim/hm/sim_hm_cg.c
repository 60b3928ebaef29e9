/* sim_hm: the modified conjugate gradient method (Baraff and Witkin 1998): the implicit step's
 * system and the deformation minimization's, with prescribed rows kept inside the solver. */
#include <math.h>
#include <string.h>

#include "sim_hm_internal.h"

/* a . b over n floats in double, in 8 interleaved partial sums (a fixed order: the same result
 * at any vector width) so the additions do not wait on each other. */
static double dot3n(const float *restrict a, const float *restrict b, size_t n)
{
    double s[8] = { 0 };
    size_t i = 0;
    for (; i + 8 <= n; i += 8)
        for (int k = 0; k < 8; k++) s[k] += (double)a[i + k] * b[i + k];
    for (; i < n; i++) s[0] += (double)a[i] * b[i];
    return ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]));
}

static void filter(const sim_hm *h, float *a)
{
    for (uint32_t i = 0; i < h->n; i++)
        if (h->fixed[i]) a[3 * i] = a[3 * i + 1] = a[3 * i + 2] = 0.0f;
}

/* A symmetric system A = L + D + U on the free rows (fixed[i] == 0; the fixed rows' results are 0
 * and their columns ignored): the forward sweep t = (D + L)^-1 r, the backward t = (D + U)^-1 r
 * with u = U t when u is not NULL (t may be r) and y = D x. */
typedef struct split_ops {
    void (*lower)(const sim_hm *h, const float *r, float *t);
    void (*upper)(const sim_hm *h, const float *r, float *t, float *u);
    void (*diag)(const sim_hm *h, const float *x, float *y);
} split_ops;

/* out = D a; returns a . out (with a = (D + L)^-1 r, r M^-1 r for the symmetric Gauss-Seidel
 * preconditioner M = (D + L) D^-1 (D + U)). */
static double d_norm(const sim_hm *h, const split_ops *o, const float *a, float *out)
{
    o->diag(h, a, out);
    return dot3n(a, out, 3 * (size_t)h->n);
}

/* CG on the free rows of A x = r preconditioned by M = (D + L) D^-1 (D + U) in Eisenstat's form:
 * CG with preconditioner D^-1 on A' = (D + L)^-1 A (D + U)^-1, whose product
 * A' p = t + (D + L)^-1 (p - D t) with t = (D + U)^-1 p (and p - D t = U t) costs two half sweeps
 * and no product by A. On entry h->r = (D + L)^-1 r, h->c = D h->r and delta = their dot product
 * (r M^-1 r); stops once delta <= stop or after the iteration limit, then adds (D + U)^-1 x' to x.
 * Uses h->q, h->s, h->w, h->xh. Returns the iterations. */
static int split_cg(sim_hm *h, const split_ops *o, double delta, double stop, float *x)
{
    const size_t n3 = 3 * (size_t)h->n;
    float *restrict r = h->r, *restrict c = h->c, *restrict q = h->q, *restrict t = h->s, *restrict w = h->w;
    float *restrict xh = h->xh;
    memset(xh, 0, n3 * sizeof *xh);
    int it = 0;
    while (it < h->p.hm.cg_iterations && delta > stop && delta > 0.0) {
        o->upper(h, c, t, w);
        o->lower(h, w, w);
        for (size_t i = 0; i < n3; i++) q[i] = t[i] + w[i];
        const double cq = dot3n(c, q, n3);
        if (!(cq > 0.0)) break;
        const float alpha = (float)(delta / cq);
        for (size_t i = 0; i < n3; i++) xh[i] += alpha * c[i], r[i] -= alpha * q[i];
        const double next = d_norm(h, o, r, w);
        const float beta = (float)(next / delta);
        for (size_t i = 0; i < n3; i++) c[i] = w[i] + beta * c[i];
        delta = next;
        it++;
    }
    if (it > 0) {
        o->upper(h, xh, xh, NULL);
        for (size_t i = 0; i < n3; i++) x[i] += xh[i];
    }
    return it;
}

/* The implicit step's system (h->bsr, h->pinv) as split_ops. */
static void sys_lower(const sim_hm *h, const float *r, float *t)
{
    sim_hm_bsr_lower_solve(&h->bsr, h->pinv, h->fixed, r, t);
}

static void sys_upper(const sim_hm *h, const float *r, float *t, float *u)
{
    sim_hm_bsr_upper_solve(&h->bsr, h->pinv, h->fixed, r, t, u);
}

static void sys_diag(const sim_hm *h, const float *x, float *y) { sim_hm_bsr_diag_apply(&h->bsr, h->fixed, x, y); }

static const split_ops sys_ops = { sys_lower, sys_upper, sys_diag };

int sim_hm_cg(sim_hm *h)
{
    const size_t n3 = 3 * (size_t)h->n;
    /* the tolerance is relative to the right-hand side of the free rows (the residual of vn = 0
     * there), whatever the start. Relative to the residual of keeping the velocity (vn = v), as
     * before, it asked for 100x reductions once resting contacts were held: the mesh near a moving
     * head is then calm and that residual tiny (31 iterations a solve at 2,304 vertices against
     * 13, 3.75-4.0 ms a frame against main's 2.8-3.0) */
    for (size_t j = 0; j < n3; j++) h->xh[j] = h->fixed[j / 3] ? h->z[j] : 0.0f;
    /* vn = the cold start z (moving with the head); s = v plus the last solve's change, less z, on
     * the free rows (the warm start is cold + s) */
    for (size_t j = 0; j < n3; j++) {
        h->s[j] = h->fixed[j / 3] ? 0.0f : h->v[j] + h->dvp[j] - h->z[j];
        h->vn[j] = h->z[j];
    }
    for (uint32_t i = 0; i < h->n; i++) { /* a sliding vertex's start keeps z along its normal */
        if (h->stick[i] != SIM_HM_SLIDING) continue;
        const float *n = h->normal + 3 * (size_t)i;
        float *si = h->s + 3 * (size_t)i;
        const float sn = si[0] * n[0] + si[1] * n[1] + si[2] * n[2];
        for (int c = 0; c < 3; c++) si[c] -= sn * n[c];
    }
    /* in one pass over the blocks each: r = rhs - A xh (the stop's), w = rhs - A z (the cold
     * start's) and q = A s on the free rows, then each swept by (D + L)^-1 */
    const float *const in[3] = { h->xh, h->vn, h->s };
    float *const out[3] = { h->r, h->w, h->q };
    sim_hm_bsr_apply3(&h->bsr, in, out);
    for (size_t i = 0; i < n3; i++) h->r[i] = h->rhs[i] - h->r[i], h->w[i] = h->rhs[i] - h->w[i];
    filter(h, h->r), filter(h, h->w), filter(h, h->q);
    sim_hm_bsr_lower_solve3(&h->bsr, h->pinv, h->fixed, out);
    const double stop = d_norm(h, &sys_ops, h->r, h->c) * (double)h->p.hm.cg_tolerance * (double)h->p.hm.cg_tolerance;
    const double cold = d_norm(h, &sys_ops, h->w, h->c);
    for (size_t i = 0; i < n3; i++) h->q[i] = h->w[i] - h->q[i];
    double delta = d_norm(h, &sys_ops, h->q, h->xh);
    if (delta < cold) { /* the warm start is nearer: vn = cold + s, r' = its residual */
        for (size_t i = 0; i < n3; i++) h->vn[i] += h->s[i];
        memcpy(h->r, h->q, n3 * sizeof *h->r);
        memcpy(h->c, h->xh, n3 * sizeof *h->c);
    } else {
        delta = cold;
        memcpy(h->r, h->w, n3 * sizeof *h->r);
    }
    const int it = split_cg(h, &sys_ops, delta, stop, h->vn);
    for (size_t j = 0; j < n3; j++) h->dvp[j] = h->vn[j] - h->v[j];
    return it;
}

/* The deformation minimization's A^T A (the mesh edges' graph Laplacian: the degree on the
 * diagonal, -1 per edge, the same for x, y and z) as split_ops; neighbour lists are ascending. */
static void lap_lower(const sim_hm *h, const float *r, float *t)
{
    const sim_hm_edges *e = &h->edges;
    for (uint32_t i = 0; i < h->n; i++) {
        float *ti = t + 3 * (size_t)i;
        const float *ri = r + 3 * (size_t)i;
        if (h->fixed[i]) {
            ti[0] = ti[1] = ti[2] = 0.0f;
            continue;
        }
        float s0 = ri[0], s1 = ri[1], s2 = ri[2];
        for (uint32_t k = e->row[i]; k < e->row[i + 1] && e->nb[k] < i; k++) {
            const float *tj = t + 3 * (size_t)e->nb[k];
            s0 += tj[0], s1 += tj[1], s2 += tj[2];
        }
        const float k = e->inv_degree[i];
        ti[0] = k * s0, ti[1] = k * s1, ti[2] = k * s2;
    }
}

static void lap_upper(const sim_hm *h, const float *r, float *t, float *u)
{
    const sim_hm_edges *e = &h->edges;
    for (uint32_t i = h->n; i-- > 0;) {
        float *ti = t + 3 * (size_t)i;
        const float *ri = r + 3 * (size_t)i;
        float s0 = 0.0f, s1 = 0.0f, s2 = 0.0f;
        if (!h->fixed[i]) {
            for (uint32_t k = e->row[i + 1]; k > e->row[i] && e->nb[k - 1] > i; k--) {
                const float *tj = t + 3 * (size_t)e->nb[k - 1];
                s0 += tj[0], s1 += tj[1], s2 += tj[2];
            }
            const float k = e->inv_degree[i];
            ti[0] = k * (ri[0] + s0), ti[1] = k * (ri[1] + s1), ti[2] = k * (ri[2] + s2);
        } else {
            ti[0] = ti[1] = ti[2] = 0.0f;
        }
        if (u) u[3 * i] = -s0, u[3 * i + 1] = -s1, u[3 * i + 2] = -s2;
    }
}

static void lap_diag(const sim_hm *h, const float *restrict x, float *restrict y)
{
    const sim_hm_edges *e = &h->edges;
    for (uint32_t i = 0; i < h->n; i++) {
        const float d = h->fixed[i] ? 0.0f : (float)(e->row[i + 1] - e->row[i]);
        for (int k = 0; k < 3; k++) y[3 * i + k] = d * x[3 * i + k];
    }
}

static const split_ops lap_ops = { lap_lower, lap_upper, lap_diag };

/* y = (A^T A) x on the free rows, 0 on the fixed. */
static void laplacian(const sim_hm *h, const float *restrict x, float *restrict y)
{
    const sim_hm_edges *e = &h->edges;
    for (uint32_t i = 0; i < h->n; i++) {
        float *yi = y + 3 * (size_t)i;
        if (h->fixed[i]) {
            yi[0] = yi[1] = yi[2] = 0.0f;
            continue;
        }
        const float *xi = x + 3 * (size_t)i, d = (float)(e->row[i + 1] - e->row[i]);
        float s0 = 0.0f, s1 = 0.0f, s2 = 0.0f;
        for (uint32_t k = e->row[i]; k < e->row[i + 1]; k++) {
            const float *xj = x + 3 * (size_t)e->nb[k];
            s0 += xj[0], s1 += xj[1], s2 += xj[2];
        }
        yi[0] = d * xi[0] - s0, yi[1] = d * xi[1] - s1, yi[2] = d * xi[2] - s2;
    }
}

void sim_hm_deform_min(sim_hm *h, const float *ref)
{
    const size_t n3 = 3 * (size_t)h->n;
    /* r = A^T A ref - A^T A x on the free rows: x = x' (the corrected positions) is the first guess */
    for (size_t i = 0; i < n3; i++) h->s[i] = ref[i] - h->x[i];
    laplacian(h, h->s, h->r);
    lap_lower(h, h->r, h->r);
    const double delta = d_norm(h, &lap_ops, h->r, h->c);
    split_cg(h, &lap_ops, delta, delta * (double)h->p.hm.cg_tolerance * (double)h->p.hm.cg_tolerance, h->x);
}
