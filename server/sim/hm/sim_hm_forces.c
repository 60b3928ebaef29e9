/* sim_hm: forces (Baraff-Witkin stretch, shear and bend conditions, the pair dampers, the corner
 * tetrahedra's volume force, paper eq. 1-2) and the implicit Euler system they give. */
#include <math.h>
#include <string.h>

#include "sim_hm_internal.h"

/* Inverts the symmetric block p in place (the identity's multiple when it is singular). */
static void invert_block(float *p)
{
    double a = p[0], b = p[1], c = p[2], d = p[3], e = p[4], f = p[5];
    double A = b * c - f * f, B = e * f - d * c, C = d * f - e * b;
    double det = a * A + d * B + e * C;
    if (!(fabs(det) > 1e-30)) {
        double t = a + b + c;
        float k = t > 0.0 ? (float)(3.0 / t) : 1.0f;
        p[0] = p[1] = p[2] = k, p[3] = p[4] = p[5] = 0.0f;
        return;
    }
    double k = 1.0 / det;
    p[0] = (float)(A * k), p[1] = (float)((a * c - e * e) * k), p[2] = (float)((a * b - d * d) * k);
    p[3] = (float)(B * k), p[4] = (float)(C * k), p[5] = (float)((d * e - a * f) * k);
}

/* Row r's condition C with gradient g (its vertices', sim_hm_rows), stiffness k and damping kd
 * (per unit mass, already scaled to the condition): the elastic force -k C g and the damper
 * -kd g (g . (v - z)) on the velocity less the head's rigid motion go to the right side as
 * dt (-k C + kd g . z) g (the damper's g . v part is A's: w = dt kd + dt^2 k); and A's blocks
 * w g_j g_k^T (column c of (j, k) = (w g_k[c]) g_j), assembled at once (the same order per block
 * as a separate pass, one visit of the row's data). */
static void condition(sim_hm *h, uint32_t r, float C, float k, float kd, float dt)
{
    sim_hm_rows *rw = &h->rows;
    const uint32_t *id = rw->v + 4 * (size_t)r, *at = rw->at + 16 * (size_t)r;
    const float *g = rw->g + 12 * (size_t)r;
    float gz = 0.0f;
    for (int j = 0; j < rw->nv[r]; j++) {
        const float *z = h->z + 3 * (size_t)id[j];
        gz += g[3 * j] * z[0] + g[3 * j + 1] * z[1] + g[3 * j + 2] * z[2];
    }
    const float s = dt * (kd * gz - k * C);
    for (int j = 0; j < rw->nv[r]; j++) {
        float *rj = h->rhs + 3 * (size_t)id[j];
        rj[0] += s * g[3 * j], rj[1] += s * g[3 * j + 1], rj[2] += s * g[3 * j + 2];
    }
    const float w = rw->w[r] = dt * kd + dt * dt * k;
    sim_hm_v4 gv4[4];
    for (int j = 0; j < 4; j++) gv4[j] = (sim_hm_v4){ g[3 * j], g[3 * j + 1], g[3 * j + 2], 0.0f };
    for (int k4 = 0; k4 < 4; k4++) {
        const float w0 = w * g[3 * k4], w1 = w * g[3 * k4 + 1], w2 = w * g[3 * k4 + 2];
        for (int j = 0; j < 4; j++)
            sim_hm_block_add(h->bsr.val + SIM_HM_BLOCK * (size_t)at[4 * j + k4], w0 * gv4[j], w1 * gv4[j], w2 * gv4[j]);
    }
}

/* Triangle t's 3 rows (stretch along u, along v, shear: rows 3 t + c) with condition values C and
 * gradients g (9 each), their stiffnesses and dampings scaled as cloth says: as condition for each (the right side's
 * terms in row order per vertex), then the stretched sides' second derivative under tension
 * (BW98: a cu_i cu_j (I - w w^T) / |w|, SPD under tension; its -b g g^T / a^2 part goes into the
 * rows' weights, b_u and b_v kept in tri_b) and the 9 blocks sum_c w_c g_c,j g_c,k^T +
 * (b_u cu_j cu_k + b_v cv_j cv_k) I. */
static void triangle(sim_hm *h, uint32_t t, const float C[3], const float g[3][9], float dt)
{
    sim_hm_cloth *cl = &h->cloth;
    const float ks = h->p.hm.stretch_stiffness, kh = h->p.hm.shear_stiffness, kdp = h->p.hm.damping;
    const float *sc = cl->tri_s + 3 * (size_t)t;
    const float k[3] = { ks * sc[0], ks * sc[1], kh * sc[2] }, kd[3] = { kdp * sc[0], kdp * sc[1], kdp * sc[2] };
    sim_hm_rows *rw = &h->rows;
    const uint32_t r = 3 * t, *id = rw->v + 4 * (size_t)r, *at = rw->at + 16 * (size_t)r;
    float *w = rw->w + r, s[3];
    for (int c = 0; c < 3; c++) memcpy(rw->g + 12 * (size_t)(r + c), g[c], sizeof g[c]); /* the 4th vertex's 3 unused */
    const float *z[3] = { h->z + 3 * (size_t)id[0], h->z + 3 * (size_t)id[1], h->z + 3 * (size_t)id[2] };
    for (int c = 0; c < 3; c++) {
        float gz = 0.0f;
        for (int j = 0; j < 3; j++) gz += g[c][3 * j] * z[j][0] + g[c][3 * j + 1] * z[j][1] + g[c][3 * j + 2] * z[j][2];
        s[c] = dt * (kd[c] * gz - k[c] * C[c]);
        w[c] = dt * kd[c] + dt * dt * k[c];
    }
    for (int j = 0; j < 3; j++) {
        float *rj = h->rhs + 3 * (size_t)id[j];
        for (int c = 0; c < 3; c++) rj[0] += s[c] * g[c][3 * j], rj[1] += s[c] * g[c][3 * j + 1], rj[2] += s[c] * g[c][3 * j + 2];
    }
    const float a = cl->tri_a[t], inv_a = 1.0f / a;
    for (int c = 0; c < 2; c++) {
        const float len = C[c] * inv_a + 1.0f, b = C[c] > 0.0f ? dt * dt * ks * sc[c] * C[c] * a / len : 0.0f;
        cl->tri_b[2 * t + c] = b;
        w[c] -= b * inv_a * inv_a;
    }
    const float bu = cl->tri_b[2 * t], bv = cl->tri_b[2 * t + 1];
    float cu[3], cv[3];
    sim_hm_bw_coefficients(cl->tri_c + 4 * (size_t)t, cu, cv);
    sim_hm_v4 gv[3][3];
    for (int q = 0; q < 3; q++)
        for (int j = 0; j < 3; j++) gv[q][j] = (sim_hm_v4){ g[q][3 * j], g[q][3 * j + 1], g[q][3 * j + 2], 0.0f };
    for (int kk = 0; kk < 3; kk++)
        for (int j = 0; j < 3; j++) {
            const float d = bu * cu[j] * cu[kk] + bv * cv[j] * cv[kk];
            sim_hm_v4 col[3];
            for (int c = 0; c < 3; c++) {
                sim_hm_v4 e = { 0.0f, 0.0f, 0.0f, 0.0f };
                e[c] = d;
                col[c] = e + (w[0] * gv[0][kk][c]) * gv[0][j] + (w[1] * gv[1][kk][c]) * gv[1][j] + (w[2] * gv[2][kk][c]) * gv[2][j];
            }
            sim_hm_block_add(h->bsr.val + SIM_HM_BLOCK * (size_t)at[4 * j + kk], col[0], col[1], col[2]);
        }
}

/* The triangles' stretch and shear (BW98 eq. 10-11) and the bends (eq. 12, C = theta - theta0).
 * Each condition's k and kd are the parameters' rates per unit mass scaled so that k' C^2 is k
 * times a squared length: 1 / a for the triangles (k' C^2 = k a e^2 for a strain e, as a spring
 * of length sqrt(a) stretched by e), h1 h2 for a bend (its opposite vertices' heights over the
 * edge: k' theta^2 = k (h theta)^2, a spring on the tip's displacement). */
static void cloth(sim_hm *h, float dt)
{
    sim_hm_cloth *cl = &h->cloth;
    sim_hm_rows *rw = &h->rows;
    const float kb = h->p.hm.bend_stiffness, kd = h->p.hm.damping;
    const float *x = h->x;
    for (uint32_t t = 0; t < cl->ntri; t++) {
        const uint32_t *id = rw->v + 4 * (size_t)(3 * t);
        float C[3], g[3][9];
        sim_hm_bw_stretch_shear(x + 3 * (size_t)id[0], x + 3 * (size_t)id[1], x + 3 * (size_t)id[2], cl->tri_c + 4 * (size_t)t,
                                cl->tri_a[t], C, g);
        triangle(h, t, C, g, dt);
    }
    for (uint32_t b = 0; b < cl->nbend; b++) {
        const uint32_t r = rw->bend0 + b, *id = rw->v + 4 * (size_t)r;
        float *g = rw->g + 12 * (size_t)r, theta;
        if (!sim_hm_bw_bend(x + 3 * (size_t)id[0], x + 3 * (size_t)id[1], x + 3 * (size_t)id[2], x + 3 * (size_t)id[3], &theta, g)) {
            memset(g, 0, 12 * sizeof *g);
            rw->w[r] = 0.0f;
            continue;
        }
        const float pi = 3.14159265f, d = theta - cl->bend_theta0[b];
        const float C = d > pi ? d - 2.0f * pi : d < -pi ? d + 2.0f * pi : d; /* in [-pi, pi] */
        condition(h, r, C, kb * cl->bend_scale[b], kd * cl->bend_scale[b], dt);
    }
}

/* The volume force f_i = -k' C dC/dx_i with C = e1 . (e2 x e3) / 6 - V0 and k' = k |V0|^(2/3) / V0^2
 * (so that k is a rate per unit mass whatever the tetrahedron's size). */
static void volumes(sim_hm *h, float dt)
{
    const sim_hm_tets *t = &h->tets;
    sim_hm_rows *rw = &h->rows;
    const float kv = h->p.hm.volume_stiffness;
    const float *x = h->x;
    for (uint32_t i = 0; i < t->n; i++) {
        const uint32_t r = rw->tet0 + i, *id = rw->v + 4 * (size_t)r;
        const float *p0 = x + 3 * (size_t)id[0];
        core_vec3 e1 = core_v3(x[3 * id[1]] - p0[0], x[3 * id[1] + 1] - p0[1], x[3 * id[1] + 2] - p0[2]);
        core_vec3 e2 = core_v3(x[3 * id[2]] - p0[0], x[3 * id[2] + 1] - p0[1], x[3 * id[2] + 2] - p0[2]);
        core_vec3 e3 = core_v3(x[3 * id[3]] - p0[0], x[3 * id[3] + 1] - p0[1], x[3 * id[3] + 2] - p0[2]);
        core_vec3 g1 = core_v3_scale(core_v3_cross(e2, e3), 1.0f / 6.0f);
        core_vec3 g2 = core_v3_scale(core_v3_cross(e3, e1), 1.0f / 6.0f);
        core_vec3 g3 = core_v3_scale(core_v3_cross(e1, e2), 1.0f / 6.0f);
        core_vec3 g0 = core_v3_scale(core_v3_add(core_v3_add(g1, g2), g3), -1.0f);
        float *g = rw->g + 12 * (size_t)r;
        const core_vec3 gs[4] = { g0, g1, g2, g3 };
        for (int j = 0; j < 4; j++) g[3 * j] = gs[j].x, g[3 * j + 1] = gs[j].y, g[3 * j + 2] = gs[j].z;
        condition(h, r, core_v3_dot(e1, g1) - t->v0[i], kv * t->scale[i], 0.0f, dt);
    }
}

/* The dampers -kd ((v_a - v_b) - (z_a - z_b)) on each pair (sim_hm_dampers): dt kd I on the
 * blocks, the head's part on the right side. */
static void dampers(sim_hm *h, float dt)
{
    sim_hm_dampers *d = &h->damp;
    const float c = d->c = dt * h->p.hm.damping;
    float *val = h->bsr.val;
    for (uint32_t i = 0; i < d->n; i++) {
        const uint32_t a = d->a[i], b = d->b[i];
        float *ra = h->rhs + 3 * (size_t)a, *rb = h->rhs + 3 * (size_t)b;
        const float *za = h->z + 3 * (size_t)a, *zb = h->z + 3 * (size_t)b;
        for (int k = 0; k < 3; k++) {
            const float r = c * (za[k] - zb[k]);
            ra[k] += r, rb[k] -= r;
        }
        float *da = val + SIM_HM_BLOCK * (size_t)h->bsr.diag[a], *db = val + SIM_HM_BLOCK * (size_t)h->bsr.diag[b];
        float *ab = val + SIM_HM_BLOCK * (size_t)d->at[2 * i], *ba = val + SIM_HM_BLOCK * (size_t)d->at[2 * i + 1];
        for (int k = 0; k < 3; k++) da[4 * k] += c, db[4 * k] += c, ab[4 * k] -= c, ba[4 * k] -= c;
    }
}

/* The air drag acts on the velocity relative to still air, up to SIM_HM_DRAG_CAP (past it, it only
 * over-damps the mesh's return to its rest shape); SIM_HM_SWING_DAMPING's missing part relative
 * to the head. */
void sim_hm_forces(sim_hm *h, const float accel[3], float dt)
{
    const float drag = h->p.air_drag < SIM_HM_DRAG_CAP ? h->p.air_drag : SIM_HM_DRAG_CAP;
    const float swing = drag < SIM_HM_SWING_DAMPING ? SIM_HM_SWING_DAMPING - drag : 0.0f;
    h->diag = 1.0f + dt * (drag + swing);
    memset(h->bsr.val, 0, SIM_HM_BLOCK * (size_t)h->bsr.nnz * sizeof *h->bsr.val);
    for (uint32_t i = 0; i < h->n; i++) {
        float *r = h->rhs + 3 * (size_t)i, *d = h->bsr.val + SIM_HM_BLOCK * (size_t)h->bsr.diag[i];
        const float *v = h->v + 3 * (size_t)i, *z = h->z + 3 * (size_t)i;
        for (int k = 0; k < 3; k++) r[k] = v[k] + dt * (accel[k] + swing * z[k]);
        d[0] = d[4] = d[8] = h->diag;
    }
    cloth(h, dt);
    volumes(h, dt);
    dampers(h, dt);
    for (uint32_t i = 0; i < h->n; i++) {
        const float *d = h->bsr.val + SIM_HM_BLOCK * (size_t)h->bsr.diag[i];
        float *p = h->pinv + 6 * (size_t)i;
        p[0] = d[0], p[1] = d[4], p[2] = d[8], p[3] = d[3], p[4] = d[6], p[5] = d[7];
        invert_block(p);
    }
}

/* Block b's column c times a 3-vector: B(:, c) . a is (B^T a)_c. */
static float col_dot(const float *b, int c, const float n[3]) { return b[3 * c] * n[0] + b[3 * c + 1] * n[1] + b[3 * c + 2] * n[2]; }

/* b = (I - n n^T) b when left, b (I - n n^T) otherwise (SIM_HM_BLOCK layout). */
static void block_filter(float *b, const float n[3], bool left)
{
    if (left) {
        for (int c = 0; c < 3; c++) {
            const float t = col_dot(b, c, n);
            for (int r = 0; r < 3; r++) b[3 * c + r] -= n[r] * t;
        }
        return;
    }
    float bn[3];
    for (int r = 0; r < 3; r++) bn[r] = b[r] * n[0] + b[3 + r] * n[1] + b[6 + r] * n[2];
    for (int c = 0; c < 3; c++)
        for (int r = 0; r < 3; r++) b[3 * c + r] -= bn[r] * n[c];
}

/* The block (j, i) of m (the transposed position of (i, j)), found in row j's ascending columns. */
static uint32_t block_at(const sim_hm_bsr *m, uint32_t j, uint32_t i)
{
    uint32_t lo = m->row[j], hi = m->row[j + 1];
    while (lo + 1 < hi) {
        const uint32_t mid = (lo + hi) / 2;
        if (m->col[mid] <= i) lo = mid;
        else hi = mid;
    }
    return lo;
}

void sim_hm_filter_sliding(sim_hm *h)
{
    sim_hm_bsr *m = &h->bsr;
    float *val = m->val;
    bool any = false;
    for (uint32_t i = 0; i < h->n; i++) {
        if (h->stick[i] != SIM_HM_SLIDING) continue;
        const float *n = h->normal + 3 * (size_t)i, *b = h->rhs + 3 * (size_t)i;
        h->nrhs[i] = n[0] * b[0] + n[1] * b[1] + n[2] * b[2];
        any = true;
    }
    if (!any) return;
    for (uint32_t i = 0; i < h->n; i++) { /* rhs -= A P z, the prescribed normal velocities' part */
        if (h->stick[i] != SIM_HM_SLIDING) continue;
        const float *n = h->normal + 3 * (size_t)i, *zi = h->z + 3 * (size_t)i;
        const float zn = n[0] * zi[0] + n[1] * zi[1] + n[2] * zi[2];
        for (uint32_t k = m->row[i]; k < m->row[i + 1]; k++) {
            float *nr = h->nrow + 3 * (size_t)k, *rj = h->rhs + 3 * (size_t)m->col[k];
            const bool free_row = !h->fixed[m->col[k]];
            for (int c = 0; c < 3; c++) {
                nr[c] = col_dot(val + SIM_HM_BLOCK * (size_t)k, c, n);
                if (free_row) rj[c] -= zn * nr[c];
            }
        }
    }
    for (uint32_t i = 0; i < h->n; i++) {
        if (h->stick[i] != SIM_HM_SLIDING) continue;
        const float *n = h->normal + 3 * (size_t)i, *zi = h->z + 3 * (size_t)i;
        float *ri = h->rhs + 3 * (size_t)i;
        const float zn = n[0] * zi[0] + n[1] * zi[1] + n[2] * zi[2], rn = n[0] * ri[0] + n[1] * ri[1] + n[2] * ri[2];
        for (int c = 0; c < 3; c++) ri[c] += (zn - rn) * n[c];
        for (uint32_t k = m->row[i]; k < m->row[i + 1]; k++) {
            const uint32_t j = m->col[k];
            block_filter(val + SIM_HM_BLOCK * (size_t)k, n, true);
            if (j == i) {
                block_filter(val + SIM_HM_BLOCK * (size_t)k, n, false);
                for (int c = 0; c < 3; c++)
                    for (int r = 0; r < 3; r++) val[SIM_HM_BLOCK * (size_t)k + 3 * c + r] += n[r] * n[c];
            } else if (!h->fixed[j]) {
                block_filter(val + SIM_HM_BLOCK * (size_t)block_at(m, j, i), n, false);
            }
        }
    }
    for (uint32_t i = 0; i < h->n; i++) {
        if (h->stick[i] != SIM_HM_SLIDING) continue;
        const float *d = val + SIM_HM_BLOCK * (size_t)m->diag[i];
        float *p = h->pinv + 6 * (size_t)i;
        p[0] = d[0], p[1] = d[4], p[2] = d[8], p[3] = d[3], p[4] = d[6], p[5] = d[7];
        invert_block(p);
    }
}
