/* sim: the CPU chain pass: predict, global/local shape, follow-the-leader, collisions with contact
 * friction, DFTL velocity. */
#include <math.h>
#include <string.h>
#ifdef __AVX2__
#include <immintrin.h>
#endif

#include "sim_cpu_internal.h"

/* Strands processed together by one worker; the per-strand temporaries stay in L1. */
#define CHUNK SIM_CHUNK

/* Plain compares (not fmaxf/fminf, whose NaN rules block vectorization). */
#define MAXF(a, b) ((a) > (b) ? (a) : (b))
#define MINF(a, b) ((a) < (b) ? (a) : (b))

/* Rotates v by the unit quaternion (qx,qy,qz,qw) (branch-free, vectorizable). */
#define QROT(qx, qy, qz, qw, vx, vy, vz, ox, oy, oz)                                           \
    do {                                                                                       \
        float tx_ = 2.0f * ((qy) * (vz) - (qz) * (vy));                                        \
        float ty_ = 2.0f * ((qz) * (vx) - (qx) * (vz));                                        \
        float tz_ = 2.0f * ((qx) * (vy) - (qy) * (vx));                                        \
        ox = (vx) + (qw) * tx_ + ((qy) * tz_ - (qz) * ty_);                                    \
        oy = (vy) + (qw) * ty_ + ((qz) * tx_ - (qx) * tz_);                                    \
        oz = (vz) + (qw) * tz_ + ((qx) * ty_ - (qy) * tx_);                                    \
    } while (0)

typedef struct chain_ctx {
    sim_cpu *c;
    core_xform head;             /* this substep's head */
    float dt;                    /* substep length */
    bool use_a;                  /* add the SPH accelerations */
    const sim_wcollider *wc;     /* this substep's colliders */
    uint32_t nwc;
    const core_sdf *sdf;         /* the groom's distance grid, or NULL */
    const sim_wsdf *wsdf;        /* its placement this substep */
    const float *carry;          /* the colliders' motion over this substep (sim_step_desc.carry) */
    float friction;
} chain_ctx;

/* Pushes the points (x,y,z)[0..n) out of one collider (onto its surface). */
static void collide(const sim_wcollider *w, float *restrict x, float *restrict y, float *restrict z, size_t n)
{
    switch (w->kind) {
    case CORE_COLLIDER_SPHERE:
    case CORE_COLLIDER_CAPSULE: {
        const float ax = w->a.x, ay = w->a.y, az = w->a.z, r = w->radius;
        const float ex = w->axis[0], ey = w->axis[1], ez = w->axis[2], inv_ee = w->inv_axis2;
        for (size_t s = 0; s < n; s++) {
            float t = ((x[s] - ax) * ex + (y[s] - ay) * ey + (z[s] - az) * ez) * inv_ee;
            t = MINF(MAXF(t, 0.0f), 1.0f);
            float cx = ax + ex * t, cy = ay + ey * t, cz = az + ez * t;
            float dx = x[s] - cx, dy = y[s] - cy, dz = z[s] - cz;
            float dl = sqrtf(dx * dx + dy * dy + dz * dz);
            float k = r / MAXF(dl, 1e-12f);
            bool inside = dl < r;
            bool degenerate = dl < 1e-12f;
            x[s] = inside ? cx + dx * k : x[s];
            y[s] = inside ? (degenerate ? cy + r : cy + dy * k) : y[s];
            z[s] = inside ? cz + dz * k : z[s];
        }
        break;
    }
    case CORE_COLLIDER_ELLIPSOID: {
        const float *M = w->to_unit, *N = w->from_unit;
        const float cx = w->a.x, cy = w->a.y, cz = w->a.z;
        for (size_t s = 0; s < n; s++) {
            const float dx = x[s] - cx, dy = y[s] - cy, dz = z[s] - cz;
            const float sx = M[0] * dx + M[1] * dy + M[2] * dz;
            const float sy = M[3] * dx + M[4] * dy + M[5] * dz;
            const float sz = M[6] * dx + M[7] * dy + M[8] * dz;
            const float sl = sqrtf(sx * sx + sy * sy + sz * sz);
            const bool inside = sl < 1.0f, degenerate = sl < 1e-12f;
            const float k = 1.0f / MAXF(sl, 1e-12f);
            /* push along the unit-sphere direction; a point at the exact centre goes to +y */
            const float ux = degenerate ? 0.0f : sx * k, uy = degenerate ? 1.0f : sy * k, uz = degenerate ? 0.0f : sz * k;
            const float px = N[0] * ux + N[1] * uy + N[2] * uz;
            const float py = N[3] * ux + N[4] * uy + N[5] * uz;
            const float pz = N[6] * ux + N[7] * uy + N[8] * uz;
            x[s] = inside ? cx + px : x[s];
            y[s] = inside ? cy + py : y[s];
            z[s] = inside ? cz + pz : z[s];
        }
        break;
    }
    }
}

static void restore_strand(sim_cpu *c, size_t s, core_xform head)
{
    for (uint32_t l = 0; l < c->nv; l++) {
        size_t i = (size_t)l * c->ns + s;
        core_vec3 p = core_xform_point(head, core_v3(c->rest[0][i], c->rest[1][i], c->rest[2][i]));
        c->x[0][i] = p.x, c->x[1][i] = p.y, c->x[2][i] = p.z;
        c->v[0][i] = c->v[1][i] = c->v[2][i] = 0.0f;
    }
}

/* Per-chunk temporaries: p = previous level's final position, o = its position at the step
 * start, pr = its rest position, q = its frame, gp and go = the final and start positions of the
 * level before it; c = this level's position, co = its start position, d = the sum of this
 * level's constraint corrections. */
typedef struct chunk_tmp {
    float px[CHUNK], py[CHUNK], pz[CHUNK], ox[CHUNK], oy[CHUNK], oz[CHUNK];
    float prx[CHUNK], pry[CHUNK], prz[CHUNK], qx[CHUNK], qy[CHUNK], qz[CHUNK], qw[CHUNK];
    float cx[CHUNK], cy[CHUNK], cz[CHUNK], cox[CHUNK], coy[CHUNK], coz[CHUNK];
    float dx[CHUNK], dy[CHUNK], dz[CHUNK], bad[CHUNK];
    /* share of the velocity relative to the parent the length projection's damping takes
     * (sim_step_desc.ftl_damp): this level's, the previous level's */
    float cf[CHUNK], pf[CHUNK];
    /* contacts: positions before a round's pushes, the sum of the pushes (the contact normal),
     * segment midpoints */
    float bx[CHUNK], by[CHUNK], bz[CHUNK], nx[CHUNK], ny[CHUNK], nz[CHUNK], mx[CHUNK], my[CHUNK], mz[CHUNK];
    float dv[CHUNK]; /* a vertex's sampled grid distance after its push (+inf outside the grid) */
    float dvx[CHUNK], dvy[CHUNK], dvz[CHUNK]; /* where dv was sampled */
    float gpx[CHUNK], gpy[CHUNK], gpz[CHUNK], gox[CHUNK], goy[CHUNK], goz[CHUNK];
} chunk_tmp;


/* Where a vertex that started at (x,y,z) would be if the parent's segment had carried it
 * rigidly over the substep: the minimal rotation from the segment's start direction
 * (o - go) to its final one (p - gp), about the parent, then the parent's move o -> p. */
static inline __attribute__((always_inline)) void segment_carry(const chunk_tmp *t, size_t s, float x, float y,
                                                                float z, float *ox, float *oy, float *oz)
{
    float ax = t->ox[s] - t->gox[s], ay = t->oy[s] - t->goy[s], az = t->oz[s] - t->goz[s];
    float bx = t->px[s] - t->gpx[s], by = t->py[s] - t->gpy[s], bz = t->pz[s] - t->gpz[s];
    const float ia = 1.0f / sqrtf(MAXF(ax * ax + ay * ay + az * az, 1e-30f));
    const float ib = 1.0f / sqrtf(MAXF(bx * bx + by * by + bz * bz, 1e-30f));
    ax *= ia, ay *= ia, az *= ia, bx *= ib, by *= ib, bz *= ib;
    const float kx = ay * bz - az * by, ky = az * bx - ax * bz, kz = ax * by - ay * bx;
    const float co = ax * bx + ay * by + az * bz;
    const float vx = x - t->ox[s], vy = y - t->oy[s], vz = z - t->oz[s];
    const float kv = (kx * vx + ky * vy + kz * vz) / MAXF(1.0f + co, 1e-6f);
    *ox = t->px[s] + vx * co + (ky * vz - kz * vy) + kx * kv;
    *oy = t->py[s] + vy * co + (kz * vx - kx * vz) + ky * kv;
    *oz = t->pz[s] + vz * co + (kx * vy - ky * vx) + kz * kv;
}

/* Predict (eq. 1), global shape (11), local shape (12) and follow-the-leader (13) for one level.
 * Each shape spring pulls toward its target and its damper toward the vertex's start carried
 * by the target's frame (the head's motion; for the local spring, the parent segment's, or the
 * head's at level 1): sim_step_stiffness. */
static inline __attribute__((always_inline)) void level_constraints(const chain_ctx *ctx, chunk_tmp *restrict t,
                                                                    size_t o, size_t s0, size_t cnt, uint32_t l,
                                                                    const bool use_a)
{
    const sim_cpu *c = ctx->c;
    const float dt = ctx->dt, dt2 = dt * dt, dk = c->step.drag_keep, fd = c->step.ftl_damp;
    const float gx = c->step.accel[0], gy = c->step.accel[1], gz = c->step.accel[2];
    const float hqx = ctx->head.rot.x, hqy = ctx->head.rot.y, hqz = ctx->head.rot.z, hqw = ctx->head.rot.w;
    const float htx = ctx->head.pos.x, hty = ctx->head.pos.y, htz = ctx->head.pos.z;
    const sim_shape_weights w = c->sw[l];
    const float *C = ctx->carry;
    const float *restrict X = c->x[0] + s0 + o, *restrict Y = c->x[1] + s0 + o, *restrict Z = c->x[2] + s0 + o;
    const float *restrict VX = c->v[0] + s0 + o, *restrict VY = c->v[1] + s0 + o, *restrict VZ = c->v[2] + s0 + o;
    const float *restrict AX = c->a[0] + s0 + o, *restrict AY = c->a[1] + s0 + o, *restrict AZ = c->a[2] + s0 + o;
    const float *restrict RX = c->rest[0] + s0 + o, *restrict RY = c->rest[1] + s0 + o, *restrict RZ = c->rest[2] + s0 + o;
    for (size_t s = 0; s < cnt; s++) {
        float ax = gx, ay = gy, az = gz;
        if (use_a) ax += AX[s], ay += AY[s], az += AZ[s];
        const float xo = X[s], yo = Y[s], zo = Z[s];
        const float predx = xo + VX[s] * dk * dt + ax * dt2;
        const float predy = yo + VY[s] * dk * dt + ay * dt2;
        const float predz = zo + VZ[s] * dk * dt + az * dt2;
        float sx = predx, sy = predy, sz = predz;
        /* global shape: toward the rest position in the root (head) frame */
        float gpx, gpy, gpz;
        QROT(hqx, hqy, hqz, hqw, RX[s], RY[s], RZ[s], gpx, gpy, gpz);
        const float hx = C[0] * xo + C[1] * yo + C[2] * zo + C[3];
        const float hy = C[4] * xo + C[5] * yo + C[6] * zo + C[7];
        const float hz = C[8] * xo + C[9] * yo + C[10] * zo + C[11];
        sx += w.g * (gpx + htx - sx) + w.gd * (hx - sx);
        sy += w.g * (gpy + hty - sy) + w.gd * (hy - sy);
        sz += w.g * (gpz + htz - sz) + w.gd * (hz - sz);
        /* the DFTL correction (eq. 14) carries the local-shape and inextensibility corrections to
         * the parent; the global pull holds the vertex to the head, so its reaction is not the
         * parent's */
        const float gx0 = sx, gy0 = sy, gz0 = sz;
        /* local shape: toward the rest segment carried by the parent's frame */
        const float rx = RX[s] - t->prx[s], ry = RY[s] - t->pry[s], rz = RZ[s] - t->prz[s];
        float rrx, rry, rrz;
        QROT(t->qx[s], t->qy[s], t->qz[s], t->qw[s], rx, ry, rz, rrx, rry, rrz);
        const float tx = t->px[s] + rrx, ty = t->py[s] + rry, tz = t->pz[s] + rrz;
        float lx = hx, ly = hy, lz = hz;
        if (l > 1) segment_carry(t, s, xo, yo, zo, &lx, &ly, &lz);
        sx += w.l * (tx - sx) + w.ld * (lx - sx);
        sy += w.l * (ty - sy) + w.ld * (ly - sy);
        sz += w.l * (tz - sz) + w.ld * (lz - sz);
        /* inextensibility: follow the leader at the rest length */
        const float L = sqrtf(rx * rx + ry * ry + rz * rz);
        const float ddx = t->px[s] - sx, ddy = t->py[s] - sy, ddz = t->pz[s] - sz;
        const float len = sqrtf(ddx * ddx + ddy * ddy + ddz * ddz);
        const bool ok = len > 1e-12f;
        const float k = L / MAXF(len, 1e-12f);
        sx = ok ? t->px[s] - ddx * k : tx;
        sy = ok ? t->py[s] - ddy * k : ty;
        sz = ok ? t->pz[s] - ddz * k : tz;
        t->cf[s] = MINF(MAXF(1.0f - k, 0.0f) * fd, 1.0f);
        t->cx[s] = sx, t->cy[s] = sy, t->cz[s] = sz;
        t->dx[s] = sx - gx0, t->dy[s] = sy - gy0, t->dz[s] = sz - gz0;
        t->cox[s] = xo, t->coy[s] = yo, t->coz[s] = zo;
    }
}

/* Writes a level: its velocity with the DFTL correction (eq. 14: sd times the correction d of
 * the level after it; sd = 0 for the tip), then internal damping: the share keep (1 - f) of its
 * velocity relative to its parent's final velocity PV is kept, f the length projection's damping
 * (chunk_tmp.pf). restrict parameters (not locals) so the compiler can vectorize without alias
 * checks. */
static void finalize_kernel(size_t n, float inv_dt, float sd, float keep, const float *restrict f,
                            const float *restrict PVX, const float *restrict PVY, const float *restrict PVZ,
                            float *restrict X, float *restrict Y, float *restrict Z, float *restrict VX,
                            float *restrict VY, float *restrict VZ,
                            const float *restrict px, const float *restrict py, const float *restrict pz,
                            const float *restrict ox, const float *restrict oy, const float *restrict oz,
                            const float *restrict dx, const float *restrict dy, const float *restrict dz)
{
    for (size_t s = 0; s < n; s++) {
        const float vx = (px[s] - ox[s]) * inv_dt - sd * dx[s] * inv_dt;
        const float vy = (py[s] - oy[s]) * inv_dt - sd * dy[s] * inv_dt;
        const float vz = (pz[s] - oz[s]) * inv_dt - sd * dz[s] * inv_dt;
        const float kf = keep * (1.0f - f[s]);
        VX[s] = PVX[s] + kf * (vx - PVX[s]);
        VY[s] = PVY[s] + kf * (vy - PVY[s]);
        VZ[s] = PVZ[s] + kf * (vz - PVZ[s]);
        X[s] = px[s], Y[s] = py[s], Z[s] = pz[s];
    }
}

/* Finalises level op (>= 1) of the chunk from the chain temporaries (the "previous" slots). */
static void level_finalize_prev(const chain_ctx *ctx, const chunk_tmp *t, size_t op, size_t s0, size_t cnt, float sd)
{
    sim_cpu *c = ctx->c;
    const size_t i = s0 + op, pi = i - c->ns;
    finalize_kernel(cnt, 1.0f / ctx->dt, sd, c->step.keep, t->pf, c->v[0] + pi, c->v[1] + pi, c->v[2] + pi,
                    c->x[0] + i, c->x[1] + i, c->x[2] + i, c->v[0] + i, c->v[1] + i, c->v[2] + i, t->px, t->py, t->pz, t->ox,
                    t->oy, t->oz, t->dx, t->dy, t->dz);
}

/* Carries each frame along the chain (rotate the rest direction onto the current one) and
 * shifts this level into the "previous" slots (and the previous level into the ones before). */
static void level_advance(const chain_ctx *ctx, chunk_tmp *restrict t, size_t o, size_t s0, size_t cnt)
{
    const sim_cpu *c = ctx->c;
    const float *restrict RX = c->rest[0] + s0 + o, *restrict RY = c->rest[1] + s0 + o, *restrict RZ = c->rest[2] + s0 + o;
    for (size_t s = 0; s < cnt; s++) {
        const float qx = t->qx[s], qy = t->qy[s], qz = t->qz[s], qw = t->qw[s];
        float ex = RX[s] - t->prx[s], ey = RY[s] - t->pry[s], ez = RZ[s] - t->prz[s];
        float ie = 1.0f / sqrtf(MAXF(ex * ex + ey * ey + ez * ez, 1e-30f));
        ex *= ie, ey *= ie, ez *= ie;
        float wx = t->cx[s] - t->px[s], wy = t->cy[s] - t->py[s], wz = t->cz[s] - t->pz[s];
        float dx, dy, dz;
        QROT(-qx, -qy, -qz, qw, wx, wy, wz, dx, dy, dz);
        float id = 1.0f / sqrtf(MAXF(dx * dx + dy * dy + dz * dz, 1e-30f));
        dx *= id, dy *= id, dz *= id;
        float rx = ey * dz - ez * dy, ry = ez * dx - ex * dz, rz = ex * dy - ey * dx, rw = 1.0f + ex * dx + ey * dy + ez * dz;
        float ir = 1.0f / sqrtf(MAXF(rx * rx + ry * ry + rz * rz + rw * rw, 1e-30f));
        rx *= ir, ry *= ir, rz *= ir, rw *= ir;
        float nx = qw * rx + qx * rw + qy * rz - qz * ry;
        float ny = qw * ry - qx * rz + qy * rw + qz * rx;
        float nz = qw * rz + qx * ry - qy * rx + qz * rw;
        float nw = qw * rw - qx * rx - qy * ry - qz * rz;
        float iq = 1.0f / sqrtf(MAXF(nx * nx + ny * ny + nz * nz + nw * nw, 1e-30f));
        t->qx[s] = nx * iq, t->qy[s] = ny * iq, t->qz[s] = nz * iq, t->qw[s] = nw * iq;
        /* NaN/inf in the position, the correction or the start position (which make the
         * velocity non-finite) marks the strand */
        t->bad[s] += (t->cx[s] - t->cx[s]) + (t->cy[s] - t->cy[s]) + (t->cz[s] - t->cz[s]) + (t->dx[s] - t->dx[s]) +
                     (t->dy[s] - t->dy[s]) + (t->dz[s] - t->dz[s]) + (t->cox[s] - t->cox[s]) +
                     (t->coy[s] - t->coy[s]) + (t->coz[s] - t->coz[s]);
        t->gpx[s] = t->px[s], t->gpy[s] = t->py[s], t->gpz[s] = t->pz[s];
        t->gox[s] = t->ox[s], t->goy[s] = t->oy[s], t->goz[s] = t->oz[s];
        t->px[s] = t->cx[s], t->py[s] = t->cy[s], t->pz[s] = t->cz[s];
        t->ox[s] = t->cox[s], t->oy[s] = t->coy[s], t->oz[s] = t->coz[s];
        t->pf[s] = t->cf[s];
        t->prx[s] = RX[s], t->pry[s] = RY[s], t->prz[s] = RZ[s];
    }
}

/* Min and max of v[0..n) (n >= 1); exact in any order, so the AVX2 path gives the same result. */
static void min_max(const float *restrict v, size_t n, float *lo, float *hi)
{
    float l = v[0], h = v[0];
    size_t s = 1;
#ifdef __AVX2__
    if (n >= 8) {
        __m256 vl = _mm256_loadu_ps(v), vh = vl;
        for (s = 8; s + 8 <= n; s += 8) {
            __m256 x = _mm256_loadu_ps(v + s);
            vl = _mm256_min_ps(vl, x), vh = _mm256_max_ps(vh, x);
        }
        float bl[8], bh[8];
        _mm256_storeu_ps(bl, vl);
        _mm256_storeu_ps(bh, vh);
        for (int k = 0; k < 8; k++) l = bl[k] < l ? bl[k] : l, h = bh[k] > h ? bh[k] : h;
    }
#endif
    for (; s < n; s++) {
        l = v[s] < l ? v[s] : l;
        h = v[s] > h ? v[s] : h;
    }
    *lo = l, *hi = h;
}

/* Bounding box of this level's positions and their parents in the chunk. */
static void level_bounds(const chunk_tmp *t, size_t cnt, float lo[3], float hi[3])
{
    const float *cur[3] = { t->cx, t->cy, t->cz }, *par[3] = { t->px, t->py, t->pz };
    for (int d = 0; d < 3; d++) {
        float l1, h1, l2, h2;
        min_max(cur[d], cnt, &l1, &h1);
        min_max(par[d], cnt, &l2, &h2);
        lo[d] = MINF(l1, l2), hi[d] = MAXF(h1, h2);
    }
}

/* Number of the points (x,y,z)[0..n) strictly inside one collider (no change to them). */
static size_t count_inside(const sim_wcollider *w, const float *restrict x, const float *restrict y,
                           const float *restrict z, size_t n)
{
    size_t inside = 0;
    if (w->kind == CORE_COLLIDER_ELLIPSOID) {
        const float *M = w->to_unit;
        for (size_t s = 0; s < n; s++) {
            const float dx = x[s] - w->a.x, dy = y[s] - w->a.y, dz = z[s] - w->a.z;
            const float sx = M[0] * dx + M[1] * dy + M[2] * dz;
            const float sy = M[3] * dx + M[4] * dy + M[5] * dz;
            const float sz = M[6] * dx + M[7] * dy + M[8] * dz;
            inside += sx * sx + sy * sy + sz * sz < 1.0f;
        }
        return inside;
    }
    const float ax = w->a.x, ay = w->a.y, az = w->a.z, r2 = w->radius * w->radius;
    const float ex = w->axis[0], ey = w->axis[1], ez = w->axis[2], inv_ee = w->inv_axis2;
    for (size_t s = 0; s < n; s++) {
        float t = ((x[s] - ax) * ex + (y[s] - ay) * ey + (z[s] - az) * ez) * inv_ee;
        t = MINF(MAXF(t, 0.0f), 1.0f);
        float dx = x[s] - (ax + ex * t), dy = y[s] - (ay + ey * t), dz = z[s] - (az + ez * t);
        inside += dx * dx + dy * dy + dz * dz < r2;
    }
    return inside;
}

/* Whether the boxes [lo, hi] and [wlo, whi] meet. */
static bool box_overlaps(const float lo[3], const float hi[3], const float wlo[3], const float whi[3])
{
    return lo[0] <= whi[0] && hi[0] >= wlo[0] && lo[1] <= whi[1] && hi[1] >= wlo[1] && lo[2] <= whi[2] && hi[2] >= wlo[2];
}

/* The grid's distances are exact near the surface and change by at most sqrt(3) per metre
 * across a trilinear cell: a point farther than that bound (and a cell) from where a distance
 * was sampled needs no new sample to know it is outside. */
#define SDF_SLOPE 1.7321f

/* Pushes the points (x,y,z)[0..n) whose distance to the grid's surface is under the skin out
 * along the normalised gradient to the skin (in the head frame of w). Only points inside the
 * grid's box are judged: the grid describes the character there only (a region grid cuts the
 * mesh). Mirrored by sdf_push in shaders/sim_chain.glsl.
 * With dout (and the sample positions sx, sy, sz), a point whose last sampled distance proves
 * it outside is not sampled again (the same result, SDF_SLOPE); the others are, and dout, sx,
 * sy, sz are updated (distance after the push; +inf outside the grid's box). */
static void collide_sdf(const core_sdf *sdf, const sim_wsdf *w, float *restrict x, float *restrict y,
                        float *restrict z, size_t n, float *restrict dout, float *restrict sx, float *restrict sy,
                        float *restrict sz)
{
    const float margin = (float)SIM_SDF_SKIN + sdf->cell;
    const float *M = w->to_head, *N = w->from_head, skin = (float)SIM_SDF_SKIN;
    const float ox = sdf->origin.x, oy = sdf->origin.y, oz = sdf->origin.z;
    const float hx = ox + (float)(sdf->dims[0] - 1) * sdf->cell, hy = oy + (float)(sdf->dims[1] - 1) * sdf->cell;
    const float hz = oz + (float)(sdf->dims[2] - 1) * sdf->cell;
    for (size_t s = 0; s < n; s++) {
        const float dx = x[s] - w->pos[0], dy = y[s] - w->pos[1], dz = z[s] - w->pos[2];
        const float qx = M[0] * dx + M[1] * dy + M[2] * dz;
        const float qy = M[3] * dx + M[4] * dy + M[5] * dz;
        const float qz = M[6] * dx + M[7] * dy + M[8] * dz;
        if (dout) {
            const float mx = x[s] - sx[s], my = y[s] - sy[s], mz = z[s] - sz[s];
            if (dout[s] - SDF_SLOPE * sqrtf(mx * mx + my * my + mz * mz) > margin) continue;
            dout[s] = INFINITY;
        }
        if (!(qx >= ox && qx <= hx && qy >= oy && qy <= hy && qz >= oz && qz <= hz)) continue;
        core_vec3 g;
        const float d = core_sdf_sample(sdf, core_v3(qx, qy, qz), &g);
        const float push = skin - d;
        const float gl = sqrtf(g.x * g.x + g.y * g.y + g.z * g.z);
        const bool pushed = push > 0.0f && gl > 1e-12f;
        if (pushed) {
            const float k = push / gl;
            x[s] += (N[0] * g.x + N[1] * g.y + N[2] * g.z) * k;
            y[s] += (N[3] * g.x + N[4] * g.y + N[5] * g.z) * k;
            z[s] += (N[6] * g.x + N[7] * g.y + N[8] * g.z) * k;
        }
        if (dout) dout[s] = pushed ? skin : d, sx[s] = x[s], sy[s] = y[s], sz[s] = z[s];
    }
}

/* Segment contact: pushes the midpoint of each segment parent -> vertex out of one collider (or
 * the grid when w is NULL) and moves the vertex twice as far, so that the segment clears. */
static void collide_mid(const chain_ctx *ctx, const sim_wcollider *w, chunk_tmp *restrict t, size_t cnt)
{
    for (size_t s = 0; s < cnt; s++) {
        t->mx[s] = (t->px[s] + t->cx[s]) * 0.5f;
        t->my[s] = (t->py[s] + t->cy[s]) * 0.5f;
        t->mz[s] = (t->pz[s] + t->cz[s]) * 0.5f;
        t->bx[s] = t->mx[s], t->by[s] = t->my[s], t->bz[s] = t->mz[s];
    }
    if (w) {
        collide(w, t->mx, t->my, t->mz, cnt);
    } else {
        /* a midpoint that the vertex's last sampled distance proves outside (SDF_SLOPE, over
         * the way from that sample to the vertex and on to the midpoint) is not sampled */
        const float margin = (float)SIM_SDF_SKIN + ctx->sdf->cell;
        size_t m = 0;
        uint8_t idx[CHUNK];
        for (size_t s = 0; s < cnt; s++) {
            const float hx = t->cx[s] - t->mx[s], hy = t->cy[s] - t->my[s], hz = t->cz[s] - t->mz[s];
            const float vx = t->cx[s] - t->dvx[s], vy = t->cy[s] - t->dvy[s], vz = t->cz[s] - t->dvz[s];
            const float way = sqrtf(hx * hx + hy * hy + hz * hz) + sqrtf(vx * vx + vy * vy + vz * vz);
            if (!(t->dv[s] - SDF_SLOPE * way > margin)) idx[m++] = (uint8_t)s;
        }
        float ux[CHUNK], uy[CHUNK], uz[CHUNK];
        for (size_t j = 0; j < m; j++) ux[j] = t->mx[idx[j]], uy[j] = t->my[idx[j]], uz[j] = t->mz[idx[j]];
        collide_sdf(ctx->sdf, ctx->wsdf, ux, uy, uz, m, NULL, NULL, NULL, NULL);
        for (size_t j = 0; j < m; j++) t->mx[idx[j]] = ux[j], t->my[idx[j]] = uy[j], t->mz[idx[j]] = uz[j];
    }
    for (size_t s = 0; s < cnt; s++) {
        t->cx[s] += (t->mx[s] - t->bx[s]) * 2.0f;
        t->cy[s] += (t->my[s] - t->by[s]) * 2.0f;
        t->cz[s] += (t->mz[s] - t->bz[s]) * 2.0f;
    }
}

/* One round of pushes: every collider taken (vertex, then segment midpoint), then the grid;
 * the displacement is added to the contact normal n. */
static bool contact_pushes(const chain_ctx *ctx, chunk_tmp *restrict t, size_t cnt, const sim_wcollider *const *hit,
                           uint32_t nhit, bool sdf)
{
    float sx[CHUNK], sy[CHUNK], sz[CHUNK];
    memcpy(sx, t->cx, cnt * sizeof(float));
    memcpy(sy, t->cy, cnt * sizeof(float));
    memcpy(sz, t->cz, cnt * sizeof(float));
    for (uint32_t k = 0; k < nhit; k++) {
        collide(hit[k], t->cx, t->cy, t->cz, cnt);
        collide_mid(ctx, hit[k], t, cnt);
    }
    if (sdf) {
        collide_sdf(ctx->sdf, ctx->wsdf, t->cx, t->cy, t->cz, cnt, t->dv, t->dvx, t->dvy, t->dvz);
        collide_mid(ctx, NULL, t, cnt);
    }
    float moved = 0.0f;
    for (size_t s = 0; s < cnt; s++) {
        const float dx = t->cx[s] - sx[s], dy = t->cy[s] - sy[s], dz = t->cz[s] - sz[s];
        t->nx[s] += dx, t->ny[s] += dy, t->nz[s] += dz;
        moved += fabsf(dx) + fabsf(dy) + fabsf(dz);
    }
    return moved != 0.0f;
}

/* Coulomb-like friction at the contacts of the first round, after its rest-length slide: the
 * vertex's displacement over the substep relative to the colliders (its start position carried
 * by their rigid motion), in the tangent plane of the push n, is cancelled while it is at most
 * friction |n|, else shortened by that much. Taken after the slide, it judges where the
 * constraints leave the vertex, not the prediction that the slide moves back along the segment,
 * so static friction holds hair that lies still. */
static void contact_friction(const chain_ctx *ctx, chunk_tmp *restrict t, size_t cnt)
{
    const float *C = ctx->carry, mu = ctx->friction;
    for (size_t s = 0; s < cnt; s++) {
        const float al = sqrtf(t->nx[s] * t->nx[s] + t->ny[s] * t->ny[s] + t->nz[s] * t->nz[s]);
        if (!(al > 0.0f)) continue;
        const float inv = 1.0f / al, ux = t->nx[s] * inv, uy = t->ny[s] * inv, uz = t->nz[s] * inv;
        const float ox = C[0] * t->cox[s] + C[1] * t->coy[s] + C[2] * t->coz[s] + C[3];
        const float oy = C[4] * t->cox[s] + C[5] * t->coy[s] + C[6] * t->coz[s] + C[7];
        const float oz = C[8] * t->cox[s] + C[9] * t->coy[s] + C[10] * t->coz[s] + C[11];
        const float dx = t->cx[s] - ox, dy = t->cy[s] - oy, dz = t->cz[s] - oz;
        const float dn = dx * ux + dy * uy + dz * uz;
        const float tx = dx - dn * ux, ty = dy - dn * uy, tz = dz - dn * uz;
        const float tl = sqrtf(tx * tx + ty * ty + tz * tz), lim = mu * al;
        const float f = tl <= lim ? 1.0f : lim / tl;
        t->cx[s] -= tx * f, t->cy[s] -= ty * f, t->cz[s] -= tz * f;
    }
}

/* Rest length after contact: a vertex that was pushed keeps its offset from the parent along
 * the contact normal n and slides in the tangent plane to the rest length L (so it stays on the
 * surface it was pushed onto); when the normal offset alone exceeds L, plain follow-the-leader.
 * Vertices without contact are left as they are (at L since follow-the-leader). */
static void contact_slide(const chain_ctx *ctx, chunk_tmp *restrict t, size_t o, size_t s0, size_t cnt)
{
    const sim_cpu *c = ctx->c;
    const float *restrict RX = c->rest[0] + s0 + o, *restrict RY = c->rest[1] + s0 + o, *restrict RZ = c->rest[2] + s0 + o;
    for (size_t s = 0; s < cnt; s++) {
        const float al = sqrtf(t->nx[s] * t->nx[s] + t->ny[s] * t->ny[s] + t->nz[s] * t->nz[s]);
        if (!(al > 0.0f)) continue;
        const float inv = 1.0f / al, ux = t->nx[s] * inv, uy = t->ny[s] * inv, uz = t->nz[s] * inv;
        const float rx = RX[s] - t->prx[s], ry = RY[s] - t->pry[s], rz = RZ[s] - t->prz[s];
        const float L2 = rx * rx + ry * ry + rz * rz, L = sqrtf(L2);
        const float dx = t->cx[s] - t->px[s], dy = t->cy[s] - t->py[s], dz = t->cz[s] - t->pz[s];
        const float dn = dx * ux + dy * uy + dz * uz;
        const float tx = dx - dn * ux, ty = dy - dn * uy, tz = dz - dn * uz;
        const float tl = sqrtf(tx * tx + ty * ty + tz * tz), dn2 = dn * dn;
        if (dn2 < L2 && tl > 1e-12f) {
            const float k = sqrtf(L2 - dn2) / tl;
            t->cx[s] = t->px[s] + (ux * dn + tx * k);
            t->cy[s] = t->py[s] + (uy * dn + ty * k);
            t->cz[s] = t->pz[s] + (uz * dn + tz * k);
        } else {
            const float len = sqrtf(dx * dx + dy * dy + dz * dz);
            const float k = L / MAXF(len, 1e-12f);
            t->cx[s] = len > 1e-12f ? t->px[s] + dx * k : t->cx[s];
            t->cy[s] = len > 1e-12f ? t->py[s] + dy * k : t->cy[s];
            t->cz[s] = len > 1e-12f ? t->pz[s] + dz * k : t->cz[s];
        }
    }
}

/* Contacts of one level: SIM_COLLISION_ITERATIONS rounds of pushes out of the colliders and the
 * grid (contact_pushes), each followed by the rest-length projection along the contact's tangent
 * plane (contact_slide), so a vertex ends on the surface at its rest length; the first round then
 * takes friction (contact_friction) and slides again.
 * Culling: the colliders (and the grid) whose box meets the chunk's box (this level and its
 * parents, grown by the longest segment: the rest-length projection stays within that) are
 * processed; a push can still carry a point into a collider that was skipped, so the final
 * positions are checked against the skipped ones and the rounds repeat with any that holds one of
 * them. A collider that holds no point changes nothing, and the chunks are the same for any
 * thread count, so culling never changes results. */
static void collide_level(const chain_ctx *ctx, chunk_tmp *t, size_t o, size_t s0, size_t cnt)
{
    float lo[3], hi[3];
    level_bounds(t, cnt, lo, hi);
    const float grow = ctx->c->max_segment;
    for (int d = 0; d < 3; d++) lo[d] -= grow, hi[d] += grow;
    const bool finite = lo[0] == lo[0] && lo[1] == lo[1] && lo[2] == lo[2] && hi[0] == hi[0] && hi[1] == hi[1] &&
                        hi[2] == hi[2];
    const sim_wcollider *hit[CORE_MAX_COLLIDERS];
    bool taken[CORE_MAX_COLLIDERS] = { false };
    uint32_t nhit = 0;
    for (uint32_t k = 0; k < ctx->nwc; k++)
        if (!finite || box_overlaps(lo, hi, ctx->wc[k].lo, ctx->wc[k].hi)) taken[k] = true, hit[nhit++] = &ctx->wc[k];
    bool sdf = ctx->sdf && (!finite || box_overlaps(lo, hi, ctx->wsdf->lo, ctx->wsdf->hi));
    if (nhit == 0 && !sdf) return;
    for (size_t s = 0; s < cnt; s++) t->dv[s] = -INFINITY; /* every vertex is sampled in the first round */
    memset(t->nx, 0, cnt * sizeof(float));
    memset(t->ny, 0, cnt * sizeof(float));
    memset(t->nz, 0, cnt * sizeof(float));
    for (bool first = true;; first = false) {
        for (int it = 0; it < SIM_COLLISION_ITERATIONS; it++) {
            /* a round that pushes nothing leaves the chunk as it is (the slides are done) */
            if (!contact_pushes(ctx, t, cnt, hit, nhit, sdf)) break;
            contact_slide(ctx, t, o, s0, cnt);
            if (first && it == 0) {
                contact_friction(ctx, t, cnt);
                contact_slide(ctx, t, o, s0, cnt);
            }
        }
        float flo[3], fhi[3];
        level_bounds(t, cnt, flo, fhi);
        uint32_t added = 0;
        for (uint32_t k = 0; k < ctx->nwc; k++)
            if (!taken[k] && box_overlaps(flo, fhi, ctx->wc[k].lo, ctx->wc[k].hi) && count_inside(&ctx->wc[k], t->cx, t->cy, t->cz, cnt))
                taken[k] = true, hit[nhit++] = &ctx->wc[k], added++;
        if (ctx->sdf && !sdf && box_overlaps(flo, fhi, ctx->wsdf->lo, ctx->wsdf->hi)) {
            memcpy(t->mx, t->cx, cnt * sizeof(float));
            memcpy(t->my, t->cy, cnt * sizeof(float));
            memcpy(t->mz, t->cz, cnt * sizeof(float));
            collide_sdf(ctx->sdf, ctx->wsdf, t->mx, t->my, t->mz, cnt, NULL, NULL, NULL, NULL);
            if (memcmp(t->mx, t->cx, cnt * sizeof(float)) || memcmp(t->my, t->cy, cnt * sizeof(float)) ||
                memcmp(t->mz, t->cz, cnt * sizeof(float)))
                sdf = true, added++;
        }
        if (added == 0) break;
    }
}

/* The level after l: its state (and SPH acceleration with use_a) and rest positions for the
 * chunk, fetched while level l is solved. Levels lie ns floats apart, a page or more for large
 * grooms, so the hardware prefetcher does not follow the chain from one level to the next: the
 * first loads of each level waited on memory (a quarter of the chain's time at 16,384 x 64).
 * Always inlined: GCC takes a function that only prefetches for a pure one and drops its calls. */
__attribute__((always_inline)) static inline void prefetch_level(const sim_cpu *c, size_t i, size_t cnt, bool use_a)
{
    float *const *arrays[4] = { c->x, c->v, c->rest, c->a };
    const size_t bytes = cnt * sizeof(float);
    for (int a = 0; a < (use_a ? 4 : 3); a++)
        for (int k = 0; k < 3; k++) {
            const char *p = (const char *)(arrays[a][k] + i);
            for (size_t b = 0; b < bytes; b += 64) __builtin_prefetch(p + b);
            __builtin_prefetch(p + bytes - 1); /* the last line of a run that starts mid-line */
        }
}

static void chain_chunk(const chain_ctx *ctx, chunk_tmp *restrict t, size_t s0, size_t cnt, uint64_t *nan_count)
{
    sim_cpu *c = ctx->c;
    const size_t ns = c->ns;
    const float inv_dt = 1.0f / ctx->dt;
    const float hqx = ctx->head.rot.x, hqy = ctx->head.rot.y, hqz = ctx->head.rot.z, hqw = ctx->head.rot.w;
    const core_vec3 ht = ctx->head.pos;
    float *restrict X = c->x[0] + s0, *restrict Y = c->x[1] + s0, *restrict Z = c->x[2] + s0;
    float *restrict VX = c->v[0] + s0, *restrict VY = c->v[1] + s0, *restrict VZ = c->v[2] + s0;
    const float *restrict RX = c->rest[0] + s0, *restrict RY = c->rest[1] + s0, *restrict RZ = c->rest[2] + s0;

    for (size_t s = 0; s < cnt; s++) { /* roots follow the head */
        float px, py, pz;
        QROT(hqx, hqy, hqz, hqw, RX[s], RY[s], RZ[s], px, py, pz);
        px += ht.x, py += ht.y, pz += ht.z;
        VX[s] = (px - X[s]) * inv_dt, VY[s] = (py - Y[s]) * inv_dt, VZ[s] = (pz - Z[s]) * inv_dt;
        t->ox[s] = X[s], t->oy[s] = Y[s], t->oz[s] = Z[s];
        X[s] = px, Y[s] = py, Z[s] = pz;
        t->px[s] = px, t->py[s] = py, t->pz[s] = pz;
        t->prx[s] = RX[s], t->pry[s] = RY[s], t->prz[s] = RZ[s];
        t->qx[s] = hqx, t->qy[s] = hqy, t->qz[s] = hqz, t->qw[s] = hqw;
        t->bad[s] = (px - px) + (py - py) + (pz - pz);
    }
    for (uint32_t l = 1; l < c->nv; l++) {
        const size_t o = (size_t)l * ns;
        if (l + 1 < c->nv) prefetch_level(c, s0 + o + ns, cnt, ctx->use_a);
        if (ctx->use_a)
            level_constraints(ctx, t, o, s0, cnt, l, true);
        else
            level_constraints(ctx, t, o, s0, cnt, l, false);
        if (ctx->nwc > 0 || ctx->sdf) collide_level(ctx, t, o, s0, cnt);
        if (l > 1) level_finalize_prev(ctx, t, o - ns, s0, cnt, c->step.dftl);
        level_advance(ctx, t, o, s0, cnt);
    }
    const size_t ol = (size_t)(c->nv - 1) * ns;
    const float kp = c->step.keep;
    for (size_t s = 0; s < cnt; s++) { /* the tip: no level after it, so no DFTL correction */
        const size_t i = ol + s, pi = i - ns;
        const float kf = kp * (1.0f - t->pf[s]);
        VX[i] = VX[pi] + kf * ((t->px[s] - t->ox[s]) * inv_dt - VX[pi]);
        VY[i] = VY[pi] + kf * ((t->py[s] - t->oy[s]) * inv_dt - VY[pi]);
        VZ[i] = VZ[pi] + kf * ((t->pz[s] - t->oz[s]) * inv_dt - VZ[pi]);
        X[i] = t->px[s], Y[i] = t->py[s], Z[i] = t->pz[s];
    }
    for (size_t s = 0; s < cnt; s++) {
        if (t->bad[s] != 0.0f) { /* NaN or inf somewhere along the strand */
            restore_strand(c, s0 + s, ctx->head);
            (*nan_count)++;
        }
    }
}

/* One task = one chunk: the chunks (and their collider culling) are the same for any thread
 * count and any assignment to workers, so results are bitwise identical. */
static void chain_task(void *vctx, size_t task, size_t ntasks, int worker)
{
    (void)ntasks;
    const chain_ctx *ctx = vctx;
    sim_cpu *c = ctx->c;
    const size_t s = task * CHUNK, cnt = c->ns - s < CHUNK ? c->ns - s : CHUNK;
    chunk_tmp t;
    chain_chunk(ctx, &t, s, cnt, &c->nan_per_thread[worker]);
}

void sim_cpu_chain_pass(sim_cpu *c, int k)
{
    chain_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.c = c;
    ctx.head = c->step.head[k];
    ctx.dt = c->step.h;
    ctx.use_a = c->step.sph;
    ctx.wc = c->step.col[k];
    ctx.nwc = c->step.ncolliders;
    ctx.sdf = c->step.sdf;
    ctx.wsdf = &c->step.wsdf[k];
    ctx.carry = c->step.carry[k];
    ctx.friction = c->step.friction;
    sim_pool_run_tasks(&c->pool, chain_task, &ctx, (c->ns + CHUNK - 1) / CHUNK);
}
