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

/* out = P^-1 r on the free rows, 0 on the fixed ones; returns r . out. */
static double precondition(const sim_hm *h, const float *restrict r, float *restrict out)
{
    for (uint32_t i = 0; i < h->n; i++) {
        float *o = out + 3 * (size_t)i;
        const float *p = h->pinv + 6 * (size_t)i, *ri = r + 3 * (size_t)i;
        const float k = h->fixed[i] ? 0.0f : 1.0f;
        o[0] = k * (p[0] * ri[0] + p[3] * ri[1] + p[4] * ri[2]);
        o[1] = k * (p[3] * ri[0] + p[1] * ri[1] + p[5] * ri[2]);
        o[2] = k * (p[4] * ri[0] + p[5] * ri[1] + p[2] * ri[2]);
    }
    return dot3n(r, out, 3 * (size_t)h->n);
}

static void filter(const sim_hm *h, float *a)
{
    for (uint32_t i = 0; i < h->n; i++)
        if (h->fixed[i]) a[3 * i] = a[3 * i + 1] = a[3 * i + 2] = 0.0f;
}

int sim_hm_cg(sim_hm *h)
{
    const size_t n3 = 3 * (size_t)h->n;
    /* s = the previous solve's dv on the free rows (the warm start), dv = the cold start */
    for (uint32_t i = 0; i < h->n; i++)
        for (int k = 0; k < 3; k++) {
            const size_t j = 3 * (size_t)i + (size_t)k;
            h->s[j] = h->fixed[i] ? 0.0f : h->dv[j];
            h->dv[j] = h->fixed[i] ? h->z[j] : 0.0f;
        }
    sim_hm_bsr_apply(&h->bsr, h->dv, h->q);
    for (size_t i = 0; i < n3; i++) h->r[i] = h->rhs[i] - h->q[i];
    filter(h, h->r);
    const double cold = precondition(h, h->r, h->c);
    /* the tolerance is relative to the cold start's residual whatever the start */
    const double stop = cold * (double)h->p.hm.cg_tolerance * (double)h->p.hm.cg_tolerance;
    sim_hm_bsr_apply(&h->bsr, h->s, h->q);
    filter(h, h->q);
    for (size_t i = 0; i < n3; i++) h->q[i] = h->r[i] - h->q[i];
    double delta = precondition(h, h->q, h->c);
    if (delta < cold) { /* the warm start is nearer: dv = cold + s, r = its residual */
        for (size_t i = 0; i < n3; i++) h->dv[i] += h->s[i];
        memcpy(h->r, h->q, n3 * sizeof *h->r);
    } else {
        delta = precondition(h, h->r, h->c);
    }
    int it = 0;
    while (it < h->p.hm.cg_iterations && delta > stop && delta > 0.0) {
        sim_hm_bsr_apply(&h->bsr, h->c, h->q);
        filter(h, h->q);
        const double cq = dot3n(h->c, h->q, n3);
        if (!(cq > 0.0)) break;
        const float alpha = (float)(delta / cq);
        for (size_t i = 0; i < n3; i++) h->dv[i] += alpha * h->c[i], h->r[i] -= alpha * h->q[i];
        const double next = precondition(h, h->r, h->s);
        const float beta = (float)(next / delta);
        for (size_t i = 0; i < n3; i++) h->c[i] = h->s[i] + beta * h->c[i];
        delta = next;
        it++;
    }
    return it;
}

/* y = (A^T A) x on the mesh edges, the same matrix for x, y and z. */
static void laplacian(const sim_hm *h, const float *x, float *y)
{
    memset(y, 0, 3 * (size_t)h->n * sizeof *y);
    const sim_hm_edges *e = &h->edges;
    for (uint32_t k = 0; k < e->n; k++) {
        const uint32_t a = e->a[k], b = e->b[k];
        const float d0 = x[3 * a] - x[3 * b], d1 = x[3 * a + 1] - x[3 * b + 1], d2 = x[3 * a + 2] - x[3 * b + 2];
        y[3 * a] += d0, y[3 * a + 1] += d1, y[3 * a + 2] += d2;
        y[3 * b] -= d0, y[3 * b + 1] -= d1, y[3 * b + 2] -= d2;
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
    filter(h, h->r);
    double delta = jacobi(h, h->r, h->c);
    const double stop = delta * (double)h->p.hm.cg_tolerance * (double)h->p.hm.cg_tolerance;
    for (int it = 0; it < h->p.hm.cg_iterations && delta > stop && delta > 0.0; it++) {
        laplacian(h, h->c, h->q);
        filter(h, h->q);
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
