/* sim_hm: the modified conjugate gradient method (Baraff and Witkin 1998): the implicit step's
 * system and the deformation minimization's, with prescribed rows kept inside the solver. */
#include <math.h>
#include <string.h>

#include "sim_hm_internal.h"

void sim_hm_apply(const sim_hm *h, const float *x, float *y)
{
    const float d = h->diag;
    for (size_t i = 0; i < 3 * (size_t)h->n; i++) y[i] = d * x[i];
    const sim_hm_springs *s = &h->sp;
    for (uint32_t i = 0; i < s->n; i++) {
        const uint32_t a = s->a[i], b = s->b[i];
        const float *u = s->u + 3 * (size_t)i;
        const float w0 = x[3 * a] - x[3 * b], w1 = x[3 * a + 1] - x[3 * b + 1], w2 = x[3 * a + 2] - x[3 * b + 2];
        const float al = s->alpha[i] * (u[0] * w0 + u[1] * w1 + u[2] * w2), be = s->beta[i];
        const float y0 = al * u[0] + be * w0, y1 = al * u[1] + be * w1, y2 = al * u[2] + be * w2;
        y[3 * a] += y0, y[3 * a + 1] += y1, y[3 * a + 2] += y2;
        y[3 * b] -= y0, y[3 * b + 1] -= y1, y[3 * b + 2] -= y2;
    }
    const sim_hm_tets *t = &h->tets;
    for (uint32_t i = 0; i < t->n; i++) {
        const uint32_t *id = t->v + 4 * (size_t)i;
        const float *g = t->g + 12 * (size_t)i;
        float gx = 0.0f;
        for (int j = 0; j < 4; j++) {
            const float *xj = x + 3 * (size_t)id[j];
            gx += g[3 * j] * xj[0] + g[3 * j + 1] * xj[1] + g[3 * j + 2] * xj[2];
        }
        gx *= t->w[i];
        for (int j = 0; j < 4; j++) {
            float *yj = y + 3 * (size_t)id[j];
            yj[0] += gx * g[3 * j], yj[1] += gx * g[3 * j + 1], yj[2] += gx * g[3 * j + 2];
        }
    }
}

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

/* out = D a on the free rows, 0 on the fixed; returns a . out (with a = (D + L)^-1 r, r M^-1 r for
 * M = (D + L) D^-1 (D + U), the symmetric Gauss-Seidel preconditioner). */
static double d_norm(const sim_hm *h, const float *a, float *out)
{
    sim_hm_bsr_diag_apply(&h->bsr, h->fixed, a, out);
    return dot3n(a, out, 3 * (size_t)h->n);
}

/* CG on the free rows of A dv = rhs preconditioned by M = (D + L) D^-1 (D + U) in Eisenstat's form:
 * CG with preconditioner D^-1 on A' = (D + L)^-1 A (D + U)^-1, whose product
 * A' p = t + (D + L)^-1 (p - D t) with t = (D + U)^-1 p costs two half sweeps and no product by A;
 * the solution is dv += (D + U)^-1 x'. */
int sim_hm_cg(sim_hm *h)
{
    const size_t n3 = 3 * (size_t)h->n;
    const sim_hm_bsr *m = &h->bsr;
    /* s = the previous solve's dv on the free rows (the warm start), dv = the cold start */
    for (uint32_t i = 0; i < h->n; i++)
        for (int k = 0; k < 3; k++) {
            const size_t j = 3 * (size_t)i + (size_t)k;
            h->s[j] = h->fixed[i] ? 0.0f : h->dv[j];
            h->dv[j] = h->fixed[i] ? h->z[j] : 0.0f;
        }
    sim_hm_bsr_apply(m, h->dv, h->q);
    for (size_t i = 0; i < n3; i++) h->r[i] = h->rhs[i] - h->q[i];
    filter(h, h->r);
    sim_hm_bsr_lower_solve(m, h->pinv, h->fixed, h->r, h->r);
    const double cold = d_norm(h, h->r, h->w);
    /* the tolerance is relative to the cold start's residual whatever the start */
    const double stop = cold * (double)h->p.hm.cg_tolerance * (double)h->p.hm.cg_tolerance;
    sim_hm_bsr_apply(m, h->s, h->q);
    filter(h, h->q);
    sim_hm_bsr_lower_solve(m, h->pinv, h->fixed, h->q, h->q);
    for (size_t i = 0; i < n3; i++) h->q[i] = h->r[i] - h->q[i];
    double delta = d_norm(h, h->q, h->c);
    if (delta < cold) { /* the warm start is nearer: dv = cold + s, r' = its residual */
        for (size_t i = 0; i < n3; i++) h->dv[i] += h->s[i];
        memcpy(h->r, h->q, n3 * sizeof *h->r);
    } else {
        delta = cold;
        memcpy(h->c, h->w, n3 * sizeof *h->c);
    }
    memset(h->xh, 0, n3 * sizeof *h->xh);
    int it = 0;
    while (it < h->p.hm.cg_iterations && delta > stop && delta > 0.0) {
        sim_hm_bsr_upper_solve(m, h->pinv, h->fixed, h->c, h->s);
        sim_hm_bsr_diag_apply(m, h->fixed, h->s, h->w);
        for (size_t i = 0; i < n3; i++) h->w[i] = h->c[i] - h->w[i];
        sim_hm_bsr_lower_solve(m, h->pinv, h->fixed, h->w, h->w);
        for (size_t i = 0; i < n3; i++) h->q[i] = h->s[i] + h->w[i];
        const double cq = dot3n(h->c, h->q, n3);
        if (!(cq > 0.0)) break;
        const float alpha = (float)(delta / cq);
        for (size_t i = 0; i < n3; i++) h->xh[i] += alpha * h->c[i], h->r[i] -= alpha * h->q[i];
        const double next = d_norm(h, h->r, h->w);
        const float beta = (float)(next / delta);
        for (size_t i = 0; i < n3; i++) h->c[i] = h->w[i] + beta * h->c[i];
        delta = next;
        it++;
    }
    if (it > 0) {
        sim_hm_bsr_upper_solve(m, h->pinv, h->fixed, h->xh, h->xh);
        for (size_t i = 0; i < n3; i++) h->dv[i] += h->xh[i];
    }
    return it;
}

/* y = (A^T A) x on the mesh edges (the same matrix for x, y and z) on the free rows, 0 on the fixed. */
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

/* out = r / degree on the free rows, 0 on the fixed; returns r . out. */
static double jacobi(const sim_hm *h, const float *restrict r, float *restrict out)
{
    for (uint32_t i = 0; i < h->n; i++) {
        const float k = h->fixed[i] ? 0.0f : h->edges.inv_degree[i];
        for (int j = 0; j < 3; j++) out[3 * i + j] = k * r[3 * i + j];
    }
    return dot3n(r, out, 3 * (size_t)h->n);
}

void sim_hm_deform_min(sim_hm *h, const float *ref)
{
    const size_t n3 = 3 * (size_t)h->n;
    /* r = A^T A ref - A^T A x on the free rows: x = x' (the corrected positions) is the first guess */
    for (size_t i = 0; i < n3; i++) h->s[i] = ref[i] - h->x[i];
    laplacian(h, h->s, h->r);
    double delta = jacobi(h, h->r, h->c);
    const double stop = delta * (double)h->p.hm.cg_tolerance * (double)h->p.hm.cg_tolerance;
    for (int it = 0; it < h->p.hm.cg_iterations && delta > stop && delta > 0.0; it++) {
        laplacian(h, h->c, h->q);
        const double cq = dot3n(h->c, h->q, n3);
        if (!(cq > 0.0)) break;
        const float alpha = (float)(delta / cq);
        for (size_t i = 0; i < n3; i++) h->x[i] += alpha * h->c[i], h->r[i] -= alpha * h->q[i];
        const double next = jacobi(h, h->r, h->s);
        const float beta = (float)(next / delta);
        for (size_t i = 0; i < n3; i++) h->c[i] = h->s[i] + beta * h->c[i];
        delta = next;
    }
}
