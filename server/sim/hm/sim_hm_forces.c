/* sim_hm: forces (Baraff-Witkin stretch, shear and bend conditions; the corner tetrahedra's volume
 * force, paper eq. 1-2) and the implicit Euler system they give. */
#include <math.h>
#include <string.h>

#include "sim_hm_internal.h"

/* The 3x3 block a u u^T + b I as its columns (SIM_HM_BLOCK layout). */
static void spring_block(sim_hm_v4 col[3], const float u[3], float a, float b)
{
    const sim_hm_v4 uv = { u[0], u[1], u[2], 0.0f };
    col[0] = (a * u[0]) * uv + (sim_hm_v4){ b, 0.0f, 0.0f, 0.0f };
    col[1] = (a * u[1]) * uv + (sim_hm_v4){ 0.0f, b, 0.0f, 0.0f };
    col[2] = (a * u[2]) * uv + (sim_hm_v4){ 0.0f, 0.0f, b, 0.0f };
}

/* Adds sign x the block's columns col to the block p of the system's matrix (16-byte aligned). */
static void add_block(float *p, const sim_hm_v4 col[3], float sign)
{
    sim_hm_v4 *pc = (sim_hm_v4 *)p;
    pc[0] += sign * col[0], pc[1] += sign * col[1], pc[2] += sign * col[2];
}

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

/* The springs' elastic forces along them (the geometric term only under tension) and their
 * dampers: -kd ((v_a - v_b) - (z_a - z_b)), the ends' whole relative velocity less the head's
 * rigid motion (z), so that the swinging and bending of the mesh, which hardly changes any
 * spring's length, is damped as well as its stretch, while the hair turning with the head is not;
 * the block S = alpha u u^T + beta I gets dt kd on beta, the head's part goes to the right side. */
static void springs(sim_hm *h, float dt, core_quat rot)
{
    sim_hm_springs *s = &h->sp;
    const float kind_k[3] = { h->p.hm.stretch_stiffness, h->p.hm.shear_stiffness, h->p.hm.bend_stiffness };
    const float kd = h->p.hm.damping, dt2 = dt * dt;
    const float *x = h->x;
    float *rhs = h->rhs;
    for (uint32_t i = 0; i < s->n; i++) {
        const uint32_t a = s->a[i], b = s->b[i];
        float d[3] = { x[3 * a] - x[3 * b], x[3 * a + 1] - x[3 * b + 1], x[3 * a + 2] - x[3 * b + 2] };
        float len = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        float u[3];
        if (len > 1e-7f) {
            u[0] = d[0] / len, u[1] = d[1] / len, u[2] = d[2] / len;
        } else {
            core_vec3 r = core_q_rotate(rot, core_v3(s->dir[3 * i], s->dir[3 * i + 1], s->dir[3 * i + 2]));
            u[0] = r.x, u[1] = r.y, u[2] = r.z;
        }
        const float k = kind_k[s->kind[i]];
        const float C = len - s->len[i];
        const float g = C > 0.0f ? C / len : 0.0f; /* the geometric term, kept only under tension */
        const float fe = -k * C;
        const float *za = h->z + 3 * (size_t)a, *zb = h->z + 3 * (size_t)b;
        const float r0 = dt * (fe * u[0] + kd * (za[0] - zb[0])), r1 = dt * (fe * u[1] + kd * (za[1] - zb[1])),
                    r2 = dt * (fe * u[2] + kd * (za[2] - zb[2]));
        rhs[3 * a] += r0, rhs[3 * a + 1] += r1, rhs[3 * a + 2] += r2;
        rhs[3 * b] -= r0, rhs[3 * b + 1] -= r1, rhs[3 * b + 2] -= r2;
        const float al = dt2 * k * (1.0f - g), be = dt2 * k * g + dt * kd;
        memcpy(s->u + 3 * i, u, sizeof u);
        s->alpha[i] = al, s->beta[i] = be;
        float *val = h->bsr.val;
        sim_hm_v4 S[3];
        spring_block(S, u, al, be);
        add_block(val + SIM_HM_BLOCK * (size_t)h->bsr.diag[a], S, 1.0f);
        add_block(val + SIM_HM_BLOCK * (size_t)h->bsr.diag[b], S, 1.0f);
        add_block(val + SIM_HM_BLOCK * (size_t)h->bsr.sp_at[2 * i], S, -1.0f);
        add_block(val + SIM_HM_BLOCK * (size_t)h->bsr.sp_at[2 * i + 1], S, -1.0f);
    }
}

/* The volume force f_i = -k' C dC/dx_i with C = e1 . (e2 x e3) / 6 - V0 and k' = k |V0|^(2/3) / V0^2
 * (so that k is a rate per unit mass whatever the tetrahedron's size), and its Gauss-Newton
 * Jacobian -k' G G^T (G = the four gradients). */
static void volumes(sim_hm *h, float dt)
{
    sim_hm_tets *t = &h->tets;
    const float kv = h->p.hm.volume_stiffness, dt2 = dt * dt;
    const float *x = h->x;
    for (uint32_t i = 0; i < t->n; i++) {
        const uint32_t *id = t->v + 4 * (size_t)i;
        const float *p0 = x + 3 * (size_t)id[0];
        core_vec3 e1 = core_v3(x[3 * id[1]] - p0[0], x[3 * id[1] + 1] - p0[1], x[3 * id[1] + 2] - p0[2]);
        core_vec3 e2 = core_v3(x[3 * id[2]] - p0[0], x[3 * id[2] + 1] - p0[1], x[3 * id[2] + 2] - p0[2]);
        core_vec3 e3 = core_v3(x[3 * id[3]] - p0[0], x[3 * id[3] + 1] - p0[1], x[3 * id[3] + 2] - p0[2]);
        core_vec3 g1 = core_v3_scale(core_v3_cross(e2, e3), 1.0f / 6.0f);
        core_vec3 g2 = core_v3_scale(core_v3_cross(e3, e1), 1.0f / 6.0f);
        core_vec3 g3 = core_v3_scale(core_v3_cross(e1, e2), 1.0f / 6.0f);
        core_vec3 g0 = core_v3_scale(core_v3_add(core_v3_add(g1, g2), g3), -1.0f);
        const float C = core_v3_dot(e1, g1) - t->v0[i];
        const float kk = kv * t->scale[i];
        float *g = t->g + 12 * (size_t)i;
        const core_vec3 gs[4] = { g0, g1, g2, g3 };
        for (int j = 0; j < 4; j++) g[3 * j] = gs[j].x, g[3 * j + 1] = gs[j].y, g[3 * j + 2] = gs[j].z;
        t->w[i] = dt2 * kk;
        for (int j = 0; j < 4; j++) {
            float *rj = h->rhs + 3 * (size_t)id[j];
            const float fc = -kk * C;
            rj[0] += dt * fc * g[3 * j];
            rj[1] += dt * fc * g[3 * j + 1];
            rj[2] += dt * fc * g[3 * j + 2];
        }
        /* the blocks w g_j g_k^T, column c of (j, k) = (w g_k[c]) g_j */
        const uint32_t *at = h->bsr.tet_at + 16 * (size_t)i;
        sim_hm_v4 gv4[4];
        for (int j = 0; j < 4; j++) gv4[j] = (sim_hm_v4){ g[3 * j], g[3 * j + 1], g[3 * j + 2], 0.0f };
        for (int k = 0; k < 4; k++) {
            const float w0 = t->w[i] * g[3 * k], w1 = t->w[i] * g[3 * k + 1], w2 = t->w[i] * g[3 * k + 2];
            for (int j = 0; j < 4; j++) {
                sim_hm_v4 *col = (sim_hm_v4 *)(h->bsr.val + SIM_HM_BLOCK * (size_t)at[4 * j + k]);
                col[0] += w0 * gv4[j], col[1] += w1 * gv4[j], col[2] += w2 * gv4[j];
            }
        }
    }
}

/* The air drag acts on the velocity relative to still air, up to SIM_HM_DRAG_CAP (past it, it only
 * over-damps the mesh's return to its rest shape); SIM_HM_SWING_DAMPING's missing part relative
 * to the head. */
void sim_hm_forces(sim_hm *h, const float accel[3], float dt, const core_quat head_rot)
{
    const float drag = h->p.air_drag < SIM_HM_DRAG_CAP ? h->p.air_drag : SIM_HM_DRAG_CAP;
    const float swing = drag < SIM_HM_SWING_DAMPING ? SIM_HM_SWING_DAMPING - drag : 0.0f;
    h->diag = 1.0f + dt * (drag + swing);
    memset(h->bsr.val, 0, SIM_HM_BLOCK * (size_t)h->bsr.nnz * sizeof *h->bsr.val);
    for (uint32_t i = 0; i < h->n; i++) {
        float *r = h->rhs + 3 * (size_t)i, *d = h->bsr.val + SIM_HM_BLOCK * (size_t)h->bsr.diag[i];
        const float *v = h->v + 3 * (size_t)i, *z = h->z + 3 * (size_t)i;
        for (int k = 0; k < 3; k++) r[k] = v[k] + dt * (accel[k] + swing * z[k]);
        d[0] = d[5] = d[10] = h->diag;
    }
    springs(h, dt, head_rot);
    volumes(h, dt);
    for (uint32_t i = 0; i < h->n; i++) {
        const float *d = h->bsr.val + SIM_HM_BLOCK * (size_t)h->bsr.diag[i];
        float *p = h->pinv + 6 * (size_t)i;
        p[0] = d[0], p[1] = d[5], p[2] = d[10], p[3] = d[4], p[4] = d[8], p[5] = d[9];
        invert_block(p);
    }
}

/* Block b's column c times a 3-vector: B(:, c) . a is (B^T a)_c. */
static float col_dot(const float *b, int c, const float n[3]) { return b[4 * c] * n[0] + b[4 * c + 1] * n[1] + b[4 * c + 2] * n[2]; }

/* b = (I - n n^T) b when left, b (I - n n^T) otherwise (SIM_HM_BLOCK layout). */
static void block_filter(float *b, const float n[3], bool left)
{
    if (left) {
        for (int c = 0; c < 3; c++) {
            const float t = col_dot(b, c, n);
            for (int r = 0; r < 3; r++) b[4 * c + r] -= n[r] * t;
        }
        return;
    }
    float bn[3];
    for (int r = 0; r < 3; r++) bn[r] = b[r] * n[0] + b[4 + r] * n[1] + b[8 + r] * n[2];
    for (int c = 0; c < 3; c++)
        for (int r = 0; r < 3; r++) b[4 * c + r] -= bn[r] * n[c];
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
                    for (int r = 0; r < 3; r++) val[SIM_HM_BLOCK * (size_t)k + 4 * c + r] += n[r] * n[c];
            } else if (!h->fixed[j]) {
                block_filter(val + SIM_HM_BLOCK * (size_t)block_at(m, j, i), n, false);
            }
        }
    }
    for (uint32_t i = 0; i < h->n; i++) {
        if (h->stick[i] != SIM_HM_SLIDING) continue;
        const float *d = val + SIM_HM_BLOCK * (size_t)m->diag[i];
        float *p = h->pinv + 6 * (size_t)i;
        p[0] = d[0], p[1] = d[5], p[2] = d[10], p[3] = d[4], p[4] = d[8], p[5] = d[9];
        invert_block(p);
    }
}
