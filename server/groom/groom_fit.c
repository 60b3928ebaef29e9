/* groom: fits a head ellipsoid collider to a file groom's roots (which lie on the scalp). */
#include "groom.h"
#include "groom_internal.h"

#include <math.h>
#include <stdlib.h>

#define FIT_MARGIN 0.001     /* every root lies at least this far outside (push_out's sense) */
#define FIT_MIN_AXIS 0.05    /* plausible head semi-axes, metres */
#define FIT_MAX_AXIS 0.20
#define FIT_MIN_RADIUS 0.005f /* smaller after the shrink: no collider */
#define FIT_SHAPE_WEIGHT 0.05 /* per root: pull of the proportions toward the default head */
#define FIT_SCALE_WEIGHT 0.005 /* per root: weak pull of the size toward the root spread's */
#define FIT_ITERS 60

/* The fitted parameters: centre and log semi-axes. */
typedef struct fit_params { double c[3], l[3]; } fit_params;

typedef struct fit_data {
    const double *r;       /* finite roots, 3 doubles each */
    size_t n;
    double logp[3];        /* log of the default proportions (GROOM_HEAD_R* / GROOM_HEAD_RY) */
    double logs0;          /* log of the prior scale (semi-axis y) from the root spread */
} fit_data;

static const double head_r[3] = { GROOM_HEAD_RX, GROOM_HEAD_RY, GROOM_HEAD_RZ };

static double clampd(double x, double lo, double hi) { return x < lo ? lo : x > hi ? hi : x; }

/* Solves the n x n system a x = b (a row-major, overwritten; n <= 6) by Gaussian elimination
 * with partial pivoting. Returns 0 when a pivot is under tol times the largest diagonal. */
static int solve(double *a, double *b, int n, double tol)
{
    double scale = 0.0;
    for (int i = 0; i < n; i++) scale = fmax(scale, fabs(a[i * n + i]));
    if (!(scale > 0.0) || !isfinite(scale)) return 0;
    for (int k = 0; k < n; k++) {
        int p = k;
        for (int i = k + 1; i < n; i++)
            if (fabs(a[i * n + k]) > fabs(a[p * n + k])) p = i;
        if (!(fabs(a[p * n + k]) > tol * scale)) return 0;
        if (p != k) {
            for (int j = 0; j < n; j++) {
                double t = a[k * n + j];
                a[k * n + j] = a[p * n + j];
                a[p * n + j] = t;
            }
            double t = b[k];
            b[k] = b[p];
            b[p] = t;
        }
        for (int i = k + 1; i < n; i++) {
            double f = a[i * n + k] / a[k * n + k];
            for (int j = k; j < n; j++) a[i * n + j] -= f * a[k * n + j];
            b[i] -= f * b[k];
        }
    }
    for (int k = n - 1; k >= 0; k--) {
        double s = b[k];
        for (int j = k + 1; j < n; j++) s -= a[k * n + j] * b[j];
        b[k] = s / a[k * n + k];
    }
    for (int k = 0; k < n; k++)
        if (!isfinite(b[k])) return 0;
    return 1;
}

/* Algebraic sphere fit in the space scaled by the default head proportions (an ellipsoid of
 * the default shape): |q|^2 = 2 c.q + d, q = root / proportions, about the centroid m.
 * Returns 0 when the roots do not determine it (fewer than 4, coplanar) or it is implausible. */
static int fit_shape_sphere(const fit_data *fd, const double m[3], fit_params *out)
{
    if (fd->n < 4) return 0;
    double p[3], ata[16] = { 0 }, atb[4] = { 0 };
    for (int k = 0; k < 3; k++) p[k] = head_r[k] / GROOM_HEAD_RY;
    for (size_t i = 0; i < fd->n; i++) {
        double q[3], row[4], qq = 0.0;
        for (int k = 0; k < 3; k++) {
            q[k] = (fd->r[3 * i + k] - m[k]) / p[k];
            qq += q[k] * q[k];
            row[k] = 2.0 * q[k];
        }
        row[3] = 1.0;
        for (int a = 0; a < 4; a++) {
            for (int b = 0; b < 4; b++) ata[a * 4 + b] += row[a] * row[b];
            atb[a] += row[a] * qq;
        }
    }
    if (!solve(ata, atb, 4, 1e-9)) return 0;
    double r2 = atb[3] + atb[0] * atb[0] + atb[1] * atb[1] + atb[2] * atb[2];
    if (!(r2 > 0.0)) return 0;
    double ry = sqrt(r2);
    if (!(ry >= FIT_MIN_AXIS && ry <= FIT_MAX_AXIS)) return 0;
    for (int k = 0; k < 3; k++) {
        out->c[k] = m[k] + atb[k] * p[k];
        out->l[k] = log(ry * p[k]);
    }
    return 1;
}

/* Residuals (roots: radial, sqrt(f) - 1; then shape and scale priors) and, when jac is not
 * NULL, their Jacobian (rows of 6). Returns the cost (half the squared sum). */
static double residuals(const fit_data *fd, const fit_params *x, double *res, double *jac)
{
    double rho[3], cost = 0.0, mean = 0.0;
    for (int k = 0; k < 3; k++) rho[k] = exp(x->l[k]);
    for (size_t i = 0; i < fd->n; i++) {
        double d[3], f = 0.0;
        for (int k = 0; k < 3; k++) {
            d[k] = fd->r[3 * i + k] - x->c[k];
            f += d[k] * d[k] / (rho[k] * rho[k]);
        }
        double sf = sqrt(fmax(f, 1e-12));
        res[i] = sf - 1.0;
        if (jac)
            for (int k = 0; k < 3; k++) {
                jac[6 * i + k] = -d[k] / (rho[k] * rho[k] * sf);
                jac[6 * i + 3 + k] = -d[k] * d[k] / (rho[k] * rho[k] * sf);
            }
    }
    for (int k = 0; k < 3; k++) mean += (x->l[k] - fd->logp[k]) / 3.0;
    double ws = sqrt(FIT_SHAPE_WEIGHT * (double)fd->n), wc = sqrt(FIT_SCALE_WEIGHT * (double)fd->n);
    for (int k = 0; k < 3; k++) {
        size_t row = fd->n + (size_t)k;
        res[row] = ws * (x->l[k] - fd->logp[k] - mean);
        if (jac)
            for (int j = 0; j < 6; j++) jac[6 * row + j] = j < 3 ? 0.0 : ws * ((j - 3 == k ? 1.0 : 0.0) - 1.0 / 3.0);
    }
    size_t row = fd->n + 3;
    res[row] = wc * (mean - fd->logs0);
    if (jac)
        for (int j = 0; j < 6; j++) jac[6 * row + j] = j < 3 ? 0.0 : wc / 3.0;
    for (size_t i = 0; i < fd->n + 4; i++) cost += 0.5 * res[i] * res[i];
    return cost;
}

static void clamp_axes(fit_params *x)
{
    for (int k = 0; k < 3; k++) x->l[k] = clampd(x->l[k], log(FIT_MIN_AXIS), log(FIT_MAX_AXIS));
}

/* Levenberg-Marquardt on the geometric residuals from x; semi-axes kept in the plausible range.
 * Returns 0 on allocation failure (x unchanged). */
static int refine(const fit_data *fd, fit_params *x)
{
    size_t rows = fd->n + 4;
    double *res = malloc(sizeof(double) * rows), *jac = malloc(sizeof(double) * rows * 6);
    if (!res || !jac) {
        free(res);
        free(jac);
        return 0;
    }
    double mu = 1e-3, cost = residuals(fd, x, res, jac);
    for (int it = 0; it < FIT_ITERS; it++) {
        double jtj[36] = { 0 }, g[6] = { 0 };
        for (size_t i = 0; i < rows; i++)
            for (int a = 0; a < 6; a++) {
                g[a] -= jac[6 * i + a] * res[i];
                for (int b = 0; b < 6; b++) jtj[a * 6 + b] += jac[6 * i + a] * jac[6 * i + b];
            }
        int accepted = 0;
        while (!accepted && mu < 1e12) {
            double a[36], step[6];
            for (int k = 0; k < 36; k++) a[k] = jtj[k];
            for (int k = 0; k < 6; k++) {
                a[k * 6 + k] += mu * (jtj[k * 6 + k] + 1e-9);
                step[k] = g[k];
            }
            if (!solve(a, step, 6, 1e-15)) {
                mu *= 10.0;
                continue;
            }
            fit_params t = *x;
            for (int k = 0; k < 3; k++) {
                t.c[k] += step[k];
                t.l[k] += step[3 + k];
            }
            clamp_axes(&t);
            double c = residuals(fd, &t, res, NULL);
            if (isfinite(c) && c < cost) {
                double moved = 0.0;
                for (int k = 0; k < 3; k++) moved = fmax(moved, fmax(fabs(t.c[k] - x->c[k]), fabs(t.l[k] - x->l[k])));
                *x = t;
                cost = residuals(fd, x, res, jac);
                mu = fmax(mu * 0.3, 1e-9);
                accepted = 1;
                if (moved < 1e-9) it = FIT_ITERS;
            } else {
                mu *= 10.0;
            }
        }
        if (!accepted) break;
    }
    free(res);
    free(jac);
    return 1;
}

/* f of p for the ellipsoid (c, radii + margin), float arithmetic as the colliders use it. */
static float ell_f_margin(core_vec3 p, core_vec3 c, core_vec3 radii, float margin)
{
    float x = (p.x - c.x) / (radii.x + margin), y = (p.y - c.y) / (radii.y + margin), z = (p.z - c.z) / (radii.z + margin);
    return x * x + y * y + z * z;
}

void groom_fit_colliders(core_groom *g)
{
    memset(g->colliders, 0, sizeof g->colliders);
    g->ncolliders = 0;
    if (g->nstrands == 0 || g->nverts < 2 || !g->pos) return;
    double *r = malloc(sizeof(double) * 3 * g->nstrands);
    if (!r) return;
    fit_data fd = { r, 0, { 0 }, 0 };
    double m[3] = { 0, 0, 0 }, lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (uint32_t s = 0; s < g->nstrands; s++) {
        const float *p = g->pos + (size_t)s * g->nverts * 3;
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) continue; /* ignored */
        for (int k = 0; k < 3; k++) {
            r[3 * fd.n + k] = p[k];
            m[k] += p[k];
            lo[k] = fmin(lo[k], p[k]);
            hi[k] = fmax(hi[k], p[k]);
        }
        fd.n++;
    }
    if (fd.n == 0) {
        free(r);
        return;
    }
    for (int k = 0; k < 3; k++) {
        m[k] /= (double)fd.n;
        fd.logp[k] = log(head_r[k] / GROOM_HEAD_RY);
    }
    /* The prior: the default head scaled so that its width and depth cover the roots' spread,
     * its top at the highest root, centred over the roots in x and z. */
    double scale = fmax((hi[0] - lo[0]) / (2.0 * GROOM_HEAD_RX), (hi[2] - lo[2]) / (2.0 * GROOM_HEAD_RZ));
    scale = clampd(scale, FIT_MIN_AXIS / GROOM_HEAD_RX, FIT_MAX_AXIS / GROOM_HEAD_RY);
    fd.logs0 = log(scale * GROOM_HEAD_RY);
    fit_params prior;
    for (int k = 0; k < 3; k++) prior.l[k] = log(scale * head_r[k]);
    clamp_axes(&prior);
    prior.c[0] = 0.5 * (lo[0] + hi[0]);
    prior.c[1] = hi[1] - exp(prior.l[1]);
    prior.c[2] = 0.5 * (lo[2] + hi[2]);

    fit_params x;
    if (!fit_shape_sphere(&fd, m, &x)) x = prior;
    clamp_axes(&x);
    if (!refine(&fd, &x)) x = prior;
    /* the head is under its hair: a centre above the roots' centroid (by more than a cm; or a
     * broken fit) falls back to the prior */
    int ok = x.c[1] <= m[1] + 0.01;
    for (int k = 0; k < 3; k++) ok = ok && isfinite(x.c[k]) && isfinite(x.l[k]);
    if (!ok) x = prior;

    /* shrink until every root lies on or outside, then by the margin */
    double fmin = INFINITY, rho[3];
    for (int k = 0; k < 3; k++) rho[k] = exp(x.l[k]);
    for (size_t i = 0; i < fd.n; i++) {
        double f = 0.0;
        for (int k = 0; k < 3; k++) {
            double d = (r[3 * i + k] - x.c[k]) / rho[k];
            f += d * d;
        }
        fmin = fmin < f ? fmin : f;
    }
    double shrink = fmin < 1.0 ? sqrt(fmin) : 1.0;
    core_vec3 c = core_v3((float)x.c[0], (float)x.c[1], (float)x.c[2]);
    core_vec3 radii = core_v3((float)(shrink * rho[0] - FIT_MARGIN), (float)(shrink * rho[1] - FIT_MARGIN),
                              (float)(shrink * rho[2] - FIT_MARGIN));
    /* float rounding: keep shrinking a hair until the check the solvers' arithmetic makes holds */
    int outside = 0;
    for (int tries = 0; tries < 64 && !outside; tries++) {
        outside = 1;
        for (size_t i = 0; i < fd.n && outside; i++) {
            core_vec3 p = core_v3((float)r[3 * i], (float)r[3 * i + 1], (float)r[3 * i + 2]);
            outside = ell_f_margin(p, c, radii, (float)FIT_MARGIN) >= 1.0f;
        }
        if (!outside) radii = core_v3_scale(radii, 0.99999f);
    }
    free(r);
    if (!outside) return;
    if (!(radii.x >= FIT_MIN_RADIUS && radii.y >= FIT_MIN_RADIUS && radii.z >= FIT_MIN_RADIUS)) return;
    if (!isfinite(c.x) || !isfinite(c.y) || !isfinite(c.z) || !isfinite(radii.x) || !isfinite(radii.y) ||
        !isfinite(radii.z))
        return;
    core_collider *h = &g->colliders[0];
    h->kind = CORE_COLLIDER_ELLIPSOID;
    h->a = c;
    h->radii = radii;
    h->rot = core_q_identity();
    g->ncolliders = 1;
}
