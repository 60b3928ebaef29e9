/* sim_hm: Baraff and Witkin's (1998) cloth conditions on one triangle or one pair of triangles:
 * their values and gradients. */
#include <math.h>

#include "sim_hm_internal.h"

static void sub3(const float *a, const float *b, float r[3]) { r[0] = a[0] - b[0], r[1] = a[1] - b[1], r[2] = a[2] - b[2]; }

static void cross3(const float a[3], const float b[3], float r[3])
{
    r[0] = a[1] * b[2] - a[2] * b[1], r[1] = a[2] * b[0] - a[0] * b[2], r[2] = a[0] * b[1] - a[1] * b[0];
}

static float dot3(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

bool sim_hm_bw_rest_triangle(const float *p0, const float *p1, const float *p2, const float along[3], float c[4],
                             float *area)
{
    float e1[3], e2[3], nrm[3], u[3], v[3];
    sub3(p1, p0, e1), sub3(p2, p0, e2);
    cross3(e1, e2, nrm);
    const float nl = sqrtf(dot3(nrm, nrm));
    if (!(nl > 1e-12f)) return false;
    for (int k = 0; k < 3; k++) nrm[k] /= nl;
    const float an = dot3(along, nrm);
    for (int k = 0; k < 3; k++) u[k] = along[k] - an * nrm[k];
    const float ul = sqrtf(dot3(u, u));
    if (!(ul > 1e-12f)) return false;
    for (int k = 0; k < 3; k++) u[k] /= ul;
    cross3(nrm, u, v);
    const float u1 = dot3(e1, u), v1 = dot3(e1, v), u2 = dot3(e2, u), v2 = dot3(e2, v);
    const float det = u1 * v2 - u2 * v1;
    c[0] = v2 / det, c[1] = -v1 / det, c[2] = -u2 / det, c[3] = u1 / det;
    *area = 0.5f * nl;
    return true;
}

void sim_hm_bw_coefficients(const float c[4], float cu[3], float cv[3])
{
    cu[0] = -(c[0] + c[1]), cu[1] = c[0], cu[2] = c[1];
    cv[0] = -(c[2] + c[3]), cv[1] = c[2], cv[2] = c[3];
}

void sim_hm_bw_stretch_shear(const float *x0, const float *x1, const float *x2, const float c[4], float a, float C[3],
                             float g[3][9])
{
    float d1[3], d2[3], wu[3], wv[3];
    sub3(x1, x0, d1), sub3(x2, x0, d2);
    for (int k = 0; k < 3; k++) wu[k] = c[0] * d1[k] + c[1] * d2[k], wv[k] = c[2] * d1[k] + c[3] * d2[k];
    float cu[3], cv[3];
    sim_hm_bw_coefficients(c, cu, cv);
    const float lu = sqrtf(dot3(wu, wu)), lv = sqrtf(dot3(wv, wv));
    const float su = lu > 1e-12f ? a / lu : 0.0f, sv = lv > 1e-12f ? a / lv : 0.0f;
    C[0] = a * (lu - 1.0f), C[1] = a * (lv - 1.0f), C[2] = a * dot3(wu, wv);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) {
            g[0][3 * i + k] = su * cu[i] * wu[k];
            g[1][3 * i + k] = sv * cv[i] * wv[k];
            g[2][3 * i + k] = a * (cu[i] * wv[k] + cv[i] * wu[k]);
        }
}

bool sim_hm_bw_bend(const float *x1, const float *x2, const float *x3, const float *x4, float *theta, float g[12])
{
    float a[3], b[3], n1[3], n2[3], e[3];
    sub3(x1, x3, a), sub3(x1, x4, b), cross3(a, b, n1);
    sub3(x2, x4, a), sub3(x2, x3, b), cross3(a, b, n2);
    sub3(x4, x3, e);
    const float q1 = dot3(n1, n1), q2 = dot3(n2, n2), el = sqrtf(dot3(e, e));
    if (!(q1 > 1e-24f && q2 > 1e-24f && el > 1e-12f)) return false;
    float m[3];
    cross3(n2, n1, m);
    *theta = atan2f(dot3(m, e) / el, dot3(n1, n2)); /* |n1| |n2| cancel */
    float p[3], r[3];
    sub3(x1, x4, p), sub3(x2, x4, r);
    const float s3a = dot3(p, e) / el, s3b = dot3(r, e) / el;
    sub3(x1, x3, p), sub3(x2, x3, r);
    const float s4a = -dot3(p, e) / el, s4b = -dot3(r, e) / el;
    for (int k = 0; k < 3; k++) {
        const float t1 = n1[k] / q1, t2 = n2[k] / q2;
        g[k] = el * t1, g[3 + k] = el * t2;
        g[6 + k] = s3a * t1 + s3b * t2, g[9 + k] = s4a * t1 + s4b * t2;
    }
    return true;
}
