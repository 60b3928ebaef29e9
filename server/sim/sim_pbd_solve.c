/* sim: one PBD substep (thesis 3.2): Verlet prediction, then iterations of the angular and
 * global shape constraints (XPBD, compliance 1 / stiffness), the distance constraints in even
 * then odd segments and the collision constraints; friction; one exact root-to-tip distance
 * pass with the contacts; velocities from the positions with the DFTL correction. */
#include <math.h>
#include <string.h>

#include "sim_pbd_internal.h"
#include "sim_pbd_lane.h"

static core_vec3 ld(const float *a) { return core_v3(a[0], a[1], a[2]); }
static void st(float *a, core_vec3 v) { a[0] = v.x, a[1] = v.y, a[2] = v.z; }

/* The XPBD projection (angular and global): one projection of the vector constraint x - t = 0
 * (t carried by a parent vertex of inverse mass wp, 0 when the target is fixed; x has inverse
 * mass 1) with compliance 1 / k (k per unit mass, 1/s^2) and its stiffness-proportional damper
 * k b acting on x - xc (xc: the vertex's start carried by the target's frame), multiplier lam
 * (3 floats): dl = (w (t - x) - c (x - xc) - lam) / (1 + (w + c) (1 + wp)) per component, added
 * to lam and x, wp dl taken from the parent. In terms of w = k h^2 and c = k h b the first
 * projection on a fixed target moves x by (w (t - x) + c (xc - x)) / (1 + w + c), the implicit
 * step of the DFTL solver's springs; the multiplier keeps later iterations from pulling
 * further, so the settled offset is g / k for any h and iteration count. */

/* Pushes point x out of one collider (onto its surface); the box test skips far ones. */
static void push_collider(const sim_wcollider *w, float *x)
{
    if (x[0] < w->lo[0] || x[0] > w->hi[0] || x[1] < w->lo[1] || x[1] > w->hi[1] || x[2] < w->lo[2] || x[2] > w->hi[2])
        return;
    const core_vec3 p = ld(x);
    if (w->kind == CORE_COLLIDER_ELLIPSOID) {
        const float *M = w->to_unit, *N = w->from_unit;
        const core_vec3 d = core_v3_sub(p, w->a);
        const core_vec3 u = core_v3(M[0] * d.x + M[1] * d.y + M[2] * d.z, M[3] * d.x + M[4] * d.y + M[5] * d.z,
                                    M[6] * d.x + M[7] * d.y + M[8] * d.z);
        const float ul = core_v3_len(u);
        if (!(ul < 1.0f)) return;
        const core_vec3 s = ul > 1e-12f ? core_v3_scale(u, 1.0f / ul) : core_v3(0.0f, 1.0f, 0.0f);
        st(x, core_v3_add(w->a, core_v3(N[0] * s.x + N[1] * s.y + N[2] * s.z, N[3] * s.x + N[4] * s.y + N[5] * s.z,
                                        N[6] * s.x + N[7] * s.y + N[8] * s.z)));
        return;
    }
    const core_vec3 axis = ld(w->axis);
    float t = core_v3_dot(core_v3_sub(p, w->a), axis) * w->inv_axis2;
    t = fminf(fmaxf(t, 0.0f), 1.0f);
    const core_vec3 c = core_v3_add(w->a, core_v3_scale(axis, t)), d = core_v3_sub(p, c);
    const float dl = core_v3_len(d);
    if (!(dl < w->radius)) return;
    st(x, dl > 1e-12f ? core_v3_add(c, core_v3_scale(d, w->radius / dl)) : core_v3_add(c, core_v3(0.0f, w->radius, 0.0f)));
}

/* Pushes point x out of the distance grid placed by ws, to distance target from its surface
 * (the vertex's contact floor, sim_groom_contact_floor). */
static void push_sdf(const core_sdf *sdf, const sim_wsdf *ws, float target, float *x)
{
    if (x[0] < ws->lo[0] || x[0] > ws->hi[0] || x[1] < ws->lo[1] || x[1] > ws->hi[1] || x[2] < ws->lo[2] || x[2] > ws->hi[2])
        return;
    const float *M = ws->to_head, *N = ws->from_head;
    const float dx = x[0] - ws->pos[0], dy = x[1] - ws->pos[1], dz = x[2] - ws->pos[2];
    const core_vec3 q = core_v3(M[0] * dx + M[1] * dy + M[2] * dz, M[3] * dx + M[4] * dy + M[5] * dz,
                                M[6] * dx + M[7] * dy + M[8] * dz);
    const core_vec3 o = sdf->origin;
    const float span[3] = { (float)(sdf->dims[0] - 1) * sdf->cell, (float)(sdf->dims[1] - 1) * sdf->cell,
                            (float)(sdf->dims[2] - 1) * sdf->cell };
    if (!(q.x >= o.x && q.x <= o.x + span[0] && q.y >= o.y && q.y <= o.y + span[1] && q.z >= o.z && q.z <= o.z + span[2]))
        return;
    core_vec3 g;
    const float push = target - core_sdf_sample(sdf, q, &g);
    const float gl = core_v3_len(g);
    if (!(push > 0.0f && gl > 1e-12f)) return;
    const float k = push / gl;
    x[0] += (N[0] * g.x + N[1] * g.y + N[2] * g.z) * k;
    x[1] += (N[3] * g.x + N[4] * g.y + N[5] * g.z) * k;
    x[2] += (N[6] * g.x + N[7] * g.y + N[8] * g.z) * k;
}

/* Coulomb-like contact friction (as the DFTL solver's): a vertex pushed out by n over the
 * substep keeps its displacement relative to the colliders (from oc, its start carried by their
 * motion) off the tangent plane of n while that tangential part is at most mu |n|, and has it
 * shortened by that much otherwise. */
static void friction(float *x, core_vec3 n, core_vec3 oc, float mu)
{
    const float nl = core_v3_len(n);
    if (!(nl > 0.0f)) return;
    const core_vec3 u = core_v3_scale(n, 1.0f / nl), d = core_v3_sub(ld(x), oc);
    const core_vec3 t = core_v3_sub(d, core_v3_scale(u, core_v3_dot(d, u)));
    const float tl = core_v3_len(t), lim = mu * nl;
    st(x, core_v3_sub(ld(x), core_v3_scale(t, tl <= lim ? 1.0f : lim / tl)));
}

/* Puts x at distance len from its parent p, keeping its offset along the contact normal n
 * (where it is shorter than len) and moving it on the tangent plane (the DFTL solver's
 * contact_slide); along p -> x where n is 0 or the offset is too long. */
static void slide(float *x, core_vec3 p, float len, core_vec3 n)
{
    const float nl = core_v3_len(n);
    if (!(nl > 0.0f)) return;
    const core_vec3 u = core_v3_scale(n, 1.0f / nl), d = core_v3_sub(ld(x), p);
    const float dn = core_v3_dot(d, u);
    const core_vec3 t = core_v3_sub(d, core_v3_scale(u, dn));
    const float tl = core_v3_len(t);
    if (dn * dn < len * len && tl > 1e-12f) {
        st(x, core_v3_add(p, core_v3_add(core_v3_scale(u, dn), core_v3_scale(t, sqrtf(len * len - dn * dn) / tl))));
        return;
    }
    const float dl = core_v3_len(d);
    if (dl > 1e-12f) st(x, core_v3_add(p, core_v3_scale(d, len / dl)));
}

/* A group of SIM_PBD_LANES strands in the worker's scratch, lane-minor: component d of vertex l
 * of lane j at (3 * l + d) * SIM_PBD_LANES + j (len, fl: l * SIM_PBD_LANES + j). Every constraint runs
 * the scalar arithmetic of one strand per lane, in the same order, so the compiler can vectorize
 * across the strands without changing a bit of any strand's result. */
typedef struct group_view {
    float *x, *v, *o, *r, *len, *fl; /* fl: the contact floors */
    /* per level, fixed over the substep (so not recomputed every iteration): seg = the rest
     * segment ending there under the head, e0 = the unit rest direction of the segment before it
     * under the head, gt = the global target, gc = the start carried by the head, eo = the unit
     * start direction of the segment before it, od = the start segment ending there */
    float *seg, *e0, *gt, *gc, *eo, *od;
    /* per level, over the substep: the XPBD multipliers of the global and the angular constraint
     * (3 each: they are vector constraints) and the sum of the collision pushes (the contact
     * normal friction acts against) */
    float *lg, *ll, *push;
} group_view;

#define W SIM_PBD_LANES
_Static_assert(SIM_CHUNK % SIM_PBD_LANES == 0, "a task holds whole groups");

/* Lane j of vertex l of a lane-minor array. */
static inline __attribute__((always_inline)) core_vec3 ldl(const float *a, uint32_t l, int j)
{
    const float *q = a + 3 * (size_t)l * W + j;
    return core_v3(q[0], q[W], q[2 * W]);
}

static inline __attribute__((always_inline)) void stl(float *a, uint32_t l, int j, core_vec3 v)
{
    float *q = a + 3 * (size_t)l * W + j;
    q[0] = v.x, q[W] = v.y, q[2 * W] = v.z;
}

/* Rotates v by the minimal rotation taking unit a onto unit b, on every lane. */
static inline __attribute__((always_inline)) sim_lv3 lane_min_rotate(sim_lv3 a, sim_lv3 b, sim_lv3 v)
{
    const sim_lv3 k = sim_lv3_cross(a, b);
    const sim_lane co = sim_lv3_dot(a, b), den = 1.0f + co, lo = den - den + 1e-6f;
    const sim_lane kv = sim_lv3_dot(k, v) / sim_lane_sel(den > lo, den, lo); /* fmaxf(den, 1e-6f) */
    return sim_lv3_add(sim_lv3_add(sim_lv3_scale(v, co), sim_lv3_cross(k, v)), sim_lv3_scale(k, kv));
}

/* a normalized on every lane ((0, 1, 0) where its length is about 0). */
static inline __attribute__((always_inline)) sim_lv3 lane_unit(sim_lv3 a)
{
    const sim_lane l2 = sim_lv3_dot(a, a), zero = l2 - l2, one = zero + 1.0f;
    const sim_lane_mask ok = l2 > 1e-30f;
    const sim_lv3 u = sim_lv3_scale(a, 1.0f / sim_lane_sqrt(l2));
    return (sim_lv3){ sim_lane_sel(ok, u.x, zero), sim_lane_sel(ok, u.y, one), sim_lane_sel(ok, u.z, zero) };
}

/* The angular constraint of level l >= 1 on every lane: toward its rest segment turned by the
 * minimal rotation of its parent segment from rest (under the head) to now; at level 1 the
 * head's frame. Reads level l-2 and writes l and its parent l-1 (which takes the reaction), so
 * the levels of one residue mod 3 touch disjoint vertices and can be solved in parallel. Its
 * damper acts on the motion relative to the start carried by the same frame. */
static void angular(const sim_pbd *p, const group_view *s, uint32_t l, float b)
{
    const float kl = p->kl[l];
    if (!(kl > 0.0f)) return;
    const float h = p->step.h, w = kl * h * h, c = kl * h * b;
    const sim_lv3 parent = sim_lv3_ld(s->x, l - 1), seg = sim_lv3_ld(s->seg, l);
    sim_lv3 t, xc;
    float wp, inv_den;
    if (l == 1) {
        t = sim_lv3_add(parent, seg);
        xc = sim_lv3_ld(s->gc, 1);
        wp = 0.0f, inv_den = 1.0f / (1.0f + (w + c));
    } else {
        const sim_lv3 e1 = lane_unit(sim_lv3_sub(parent, sim_lv3_ld(s->x, l - 2)));
        t = sim_lv3_add(parent, lane_min_rotate(sim_lv3_ld(s->e0, l), e1, seg));
        xc = sim_lv3_add(parent, lane_min_rotate(sim_lv3_ld(s->eo, l), e1, sim_lv3_ld(s->od, l)));
        wp = 1.0f, inv_den = 1.0f / (1.0f + (w + c) * 2.0f);
    }
    const sim_lane tv[3] = { t.x, t.y, t.z }, cv[3] = { xc.x, xc.y, xc.z };
    float *x = s->x + 3 * (size_t)l * W, *xp = s->x + 3 * (size_t)(l - 1) * W, *lam = s->ll + 3 * (size_t)l * W;
    for (int d = 0; d < 3; d++) {
        const sim_lane xd = sim_lane_ld(x + d * W), ld_ = sim_lane_ld(lam + d * W);
        const sim_lane dl = (w * (tv[d] - xd) - c * (xd - cv[d]) - ld_) * inv_den;
        sim_lane_st(lam + d * W, ld_ + dl);
        sim_lane_st(x + d * W, xd + dl);
        sim_lane_st(xp + d * W, sim_lane_ld(xp + d * W) - wp * dl);
    }
}

/* The global shape constraint of level l on every lane: toward the rest pose under the head
 * (a fixed target). */
static void global(const sim_pbd *p, const group_view *s, uint32_t l, float b)
{
    const float kg = p->kg[l];
    if (!(kg > 0.0f)) return;
    const float h = p->step.h, w = kg * h * h, c = kg * h * b;
    const float inv_den = 1.0f / (1.0f + (w + c));
    float *x = s->x + 3 * (size_t)l * W, *lam = s->lg + 3 * (size_t)l * W;
    const float *t = s->gt + 3 * (size_t)l * W, *xc = s->gc + 3 * (size_t)l * W;
    for (int i = 0; i < 3 * W; i++) {
        const float dl = (w * (t[i] - x[i]) - c * (x[i] - xc[i]) - lam[i]) * inv_den;
        lam[i] += dl;
        x[i] += dl;
    }
}

/* The distance constraint of the segment ending at level l on every lane (the root does not
 * move). */
static void distance(const group_view *s, uint32_t l)
{
    const float wa = l == 1 ? 0.0f : 0.5f, wb = 1.0f - wa;
    const sim_lv3 pa = sim_lv3_ld(s->x, l - 1), pb = sim_lv3_ld(s->x, l);
    const sim_lv3 d = sim_lv3_sub(pb, pa);
    const sim_lane dl = sim_lane_sqrt(sim_lv3_dot(d, d));
    const sim_lane_mask ok = dl > 1e-12f;
    const sim_lv3 n = sim_lv3_scale(d, (dl - sim_lane_ld(s->len + (size_t)l * W)) / dl);
    const sim_lv3 na = sim_lv3_add(pa, sim_lv3_scale(n, wa - (sim_lane){ 0 })),
                  nb = sim_lv3_sub(pb, sim_lv3_scale(n, wb - (sim_lane){ 0 }));
    sim_lv3_st(s->x, l - 1, (sim_lv3){ sim_lane_sel(ok, na.x, pa.x), sim_lane_sel(ok, na.y, pa.y), sim_lane_sel(ok, na.z, pa.z) });
    sim_lv3_st(s->x, l, (sim_lv3){ sim_lane_sel(ok, nb.x, pb.x), sim_lane_sel(ok, nb.y, pb.y), sim_lane_sel(ok, nb.z, pb.z) });
}

/* core_xform_point on every lane. */
static inline __attribute__((always_inline)) sim_lv3 lane_xform_point(core_xform x, sim_lv3 p)
{
    return sim_lv3_add(sim_lv3_q_rotate(x.rot, p), sim_lv3_splat(x.pos));
}

/* Where the rigid motion of the colliders (the head) over the substep takes p, on every lane
 * (C: rows m0 m1 m2 t). */
static inline __attribute__((always_inline)) sim_lv3 lane_carry(const float *C, sim_lv3 p)
{
    return (sim_lv3){ C[0] * p.x + C[1] * p.y + C[2] * p.z + C[3], C[4] * p.x + C[5] * p.y + C[6] * p.z + C[7],
                      C[8] * p.x + C[9] * p.y + C[10] * p.z + C[11] };
}

/* Fills the per-substep fields of s (group_view) from the starts and the rest pose. */
static void substep_frames(const sim_step_desc *sd, int k, const group_view *s, uint32_t nv)
{
    const core_xform head = sd->head[k];
    const float *C = sd->carry[k];
    for (uint32_t l = 0; l < nv; l++) {
        const sim_lv3 r = sim_lv3_ld(s->r, l), o = sim_lv3_ld(s->o, l);
        sim_lv3_st(s->gt, l, lane_xform_point(head, r));
        sim_lv3_st(s->gc, l, lane_carry(C, o));
        if (l == 0) continue;
        sim_lv3_st(s->seg, l, sim_lv3_q_rotate(head.rot, sim_lv3_sub(r, sim_lv3_ld(s->r, l - 1))));
        sim_lv3_st(s->od, l, sim_lv3_sub(o, sim_lv3_ld(s->o, l - 1)));
        if (l == 1) continue;
        sim_lv3_st(s->e0, l, lane_unit(sim_lv3_ld(s->seg, l - 1)));
        sim_lv3_st(s->eo, l, lane_unit(sim_lv3_ld(s->od, l - 1)));
    }
}

/* Whether any lane's vertex l is inside the box lo..hi (or NaN): the lanes the collision
 * pushes' own box tests would not skip. */
static bool any_in_box(const group_view *s, uint32_t l, const float lo[3], const float hi[3])
{
    const sim_lv3 x = sim_lv3_ld(s->x, l);
    const sim_lane_mask out = (x.x < lo[0]) | (x.x > hi[0]) | (x.y < lo[1]) | (x.y > hi[1]) | (x.z < lo[2]) | (x.z > hi[2]);
    int32_t all = -1;
    for (int j = 0; j < W; j++) all &= out[j];
    return all == 0;
}

/* push_collider (w) or push_sdf (sdf, ws, to the lane's contact floor) on lane j of vertex l. */
static void push_lane(const group_view *s, uint32_t l, int j, const sim_wcollider *w, const core_sdf *sdf,
                      const sim_wsdf *ws)
{
    float x[3] = { s->x[3 * l * W + j], s->x[(3 * l + 1) * W + j], s->x[(3 * l + 2) * W + j] };
    if (w) push_collider(w, x);
    else push_sdf(sdf, ws, s->fl[(size_t)l * W + j], x);
    stl(s->x, l, j, ld(x));
}

/* Pushes vertex l of every lane out of the colliders, then out of the distance grid to its
 * contact floor (the box tests skip the far ones). */
static void collide(const group_view *s, uint32_t l, const sim_step_desc *sd, int k)
{
    const sim_wcollider *wc = sd->col[k];
    for (uint32_t c = 0; c < sd->ncolliders; c++)
        if (any_in_box(s, l, wc[c].lo, wc[c].hi))
            for (int j = 0; j < W; j++) push_lane(s, l, j, &wc[c], NULL, NULL);
    if (sd->sdf && any_in_box(s, l, sd->wsdf[k].lo, sd->wsdf[k].hi))
        for (int j = 0; j < W; j++) push_lane(s, l, j, NULL, sd->sdf, &sd->wsdf[k]);
}

/* Vertex l's velocity from its start and final position, its start first moved by the share
 * sd->dftl of the correction c its successor got in the closing pass (the DFTL velocity
 * correction, eq. 9, in Verlet form); internal damping then keeps a share of it relative to
 * its parent's final velocity. */
static void lane_velocity(const sim_step_desc *sd, const group_view *s, uint32_t l, sim_lv3 c)
{
    const sim_lv3 o = sim_lv3_add(sim_lv3_ld(s->o, l), sim_lv3_scale(c, sim_lane_splat(sd->dftl)));
    const sim_lv3 vn = sim_lv3_scale(sim_lv3_sub(sim_lv3_ld(s->x, l), o), sim_lane_splat(sd->inv_h));
    const sim_lv3 pv = sim_lv3_ld(s->v, l - 1);
    sim_lv3_st(s->v, l, sim_lv3_add(pv, sim_lv3_scale(sim_lv3_sub(vn, pv), sim_lane_splat(sd->keep))));
}

/* The closing pass of a substep: one exact root-to-tip sweep of the distance constraints
 * (follow the leader: each vertex moved along its segment to the rest length from its final
 * parent), each vertex then pushed out of the colliders, slid back to its length on the
 * contact's tangent plane, friction and slid again (as the DFTL solver's contacts), and the
 * velocities (lane_velocity, one level behind the sweep; the tip's without correction). Sets
 * per lane the largest relative segment-length error |(|x_l - x_l-1|) - len| / len the
 * iterations left (before the pass moved anything; segments of length 0 count 0) and their
 * sum. */
static void close_lengths(const sim_step_desc *sd, int k, const group_view *s, uint32_t nv, sim_lane *worst_out,
                          sim_lane *sum_out)
{
    sim_lane worst = sim_lane_splat(0.0f), sum = worst;
    sim_lv3 old = sim_lv3_ld(s->x, 0); /* the parent as the iterations left it */
    for (uint32_t l = 1; l < nv; l++) {
        const sim_lv3 pa = sim_lv3_ld(s->x, l - 1), pb = sim_lv3_ld(s->x, l);
        const sim_lane len = sim_lane_ld(s->len + (size_t)l * W), zero = len - len;
        const sim_lv3 e = sim_lv3_sub(pb, old);
        const sim_lane el = sim_lane_sqrt(sim_lv3_dot(e, e)) - len;
        const sim_lane_mask pos = len > 0.0f;
        const sim_lane r = sim_lane_sel(el < 0.0f, -el, el) / sim_lane_sel(pos, len, zero + 1.0f);
        worst = sim_lane_sel(pos & (r > worst), r, worst);
        sum = sum + sim_lane_sel(pos, r, zero);
        old = pb;
        const sim_lv3 d = sim_lv3_sub(pb, pa);
        const sim_lane dl = sim_lane_sqrt(sim_lv3_dot(d, d));
        const sim_lane_mask ok = dl > 1e-12f;
        const sim_lv3 nb = sim_lv3_add(pa, sim_lv3_scale(d, len / sim_lane_sel(ok, dl, zero + 1.0f)));
        const sim_lv3 x = { sim_lane_sel(ok, nb.x, pb.x), sim_lane_sel(ok, nb.y, pb.y), sim_lane_sel(ok, nb.z, pb.z) };
        sim_lv3_st(s->x, l, x);
        collide(s, l, sd, k);
        const sim_lv3 after = sim_lv3_ld(s->x, l);
        const sim_lv3 n = sim_lv3_add(sim_lv3_ld(s->push, l), sim_lv3_sub(after, x));
        sim_lv3_st(s->push, l, n);
        const sim_lane_mask touched = (n.x != 0.0f) | (n.y != 0.0f) | (n.z != 0.0f);
        int32_t any = 0;
        for (int j = 0; j < W; j++) any |= touched[j];
        for (int j = 0; j < W && any; j++) { /* slide and friction change nothing where n is 0 */
            float y[3] = { s->x[3 * l * W + j], s->x[(3 * l + 1) * W + j], s->x[(3 * l + 2) * W + j] };
            const core_vec3 nj = ldl(s->push, l, j), pj = ldl(s->x, l - 1, j);
            const float L = s->len[(size_t)l * W + j];
            slide(y, pj, L, nj);
            if (sd->friction > 0.0f) {
                friction(y, nj, ldl(s->gc, l, j), sd->friction);
                slide(y, pj, L, nj);
            }
            stl(s->x, l, j, ld(y));
        }
        if (l > 1) lane_velocity(sd, s, l - 1, sim_lv3_sub(x, pb));
    }
    lane_velocity(sd, s, nv - 1, sim_lv3_splat(core_v3(0.0f, 0.0f, 0.0f)));
    *worst_out = worst;
    *sum_out = sum;
}

/* Copies strands s0 .. s0 + W - 1 (the last one repeated past ns) of x, v, rest, the rest
 * lengths and the contact floors into the group's lanes. */
static void group_load(const sim_pbd *p, uint32_t s0, const group_view *s)
{
    const uint32_t nv = p->nv;
    for (int j = 0; j < W; j++) {
        const uint32_t si = s0 + (uint32_t)j < p->ns ? s0 + (uint32_t)j : p->ns - 1;
        const size_t base = 3 * (size_t)si * nv;
        for (uint32_t l = 0; l < nv; l++) {
            stl(s->x, l, j, ld(p->x + base + 3 * l));
            stl(s->v, l, j, ld(p->v + base + 3 * l));
            stl(s->r, l, j, ld(p->rest + base + 3 * l));
            s->len[(size_t)l * W + j] = p->len[(size_t)si * nv + l];
            s->fl[(size_t)l * W + j] = p->contact_floor[(size_t)si * nv + l];
        }
    }
}

/* One substep of the strands s0 .. s0 + W - 1 (those below ns) in worker's scratch. */
static void group_substep(sim_pbd *p, int k, uint32_t s0, int worker)
{
    const sim_step_desc *sd = &p->step;
    const uint32_t nv = p->nv;
    const size_t m = 3 * (size_t)nv * W;
    float *w = p->scratch + (size_t)worker * SIM_PBD_SCRATCH * nv * W;
    const size_t q = nv * W; /* len and fl: one float per vertex and lane */
    const group_view s = { w,                 w + m,             w + 2 * m,         w + 3 * m,
                           w + 4 * m,         w + 4 * m + q,     w + 4 * m + 2 * q, w + 5 * m + 2 * q,
                           w + 6 * m + 2 * q, w + 7 * m + 2 * q, w + 8 * m + 2 * q, w + 9 * m + 2 * q,
                           w + 10 * m + 2 * q, w + 11 * m + 2 * q, w + 12 * m + 2 * q };
    const float h = sd->h, b = sim_step_shape_damping(h);
    const core_xform head = sd->head[k];
    const core_vec3 acc = ld(sd->accel);
    group_load(p, s0, &s);
    /* the root follows the head; the others: Verlet with air drag */
    memcpy(s.o, s.x, m * sizeof(float));
    const sim_lv3 root = lane_xform_point(head, sim_lv3_ld(s.r, 0));
    sim_lv3_st(s.v, 0, sim_lv3_scale(sim_lv3_sub(root, sim_lv3_ld(s.x, 0)), sim_lane_splat(sd->inv_h)));
    sim_lv3_st(s.x, 0, root);
    const sim_lv3 ah = sim_lv3_splat(core_v3_scale(acc, h * h));
    for (uint32_t l = 1; l < nv; l++) {
        const sim_lv3 v = sim_lv3_scale(sim_lv3_ld(s.v, l), sim_lane_splat(sd->drag_keep));
        sim_lv3_st(s.x, l, sim_lv3_add(sim_lv3_ld(s.x, l), sim_lv3_add(sim_lv3_scale(v, sim_lane_splat(h)), ah)));
    }
    substep_frames(sd, k, &s, nv);
    memset(s.lg, 0, m * sizeof(float));
    memset(s.ll, 0, m * sizeof(float));
    memset(s.push, 0, m * sizeof(float));
    for (int it = 0; it < p->params.pbd_iterations; it++) {
        for (uint32_t phase = 0; phase < 3; phase++)
            for (uint32_t l = 1 + phase; l < nv; l += 3) angular(p, &s, l, b);
        for (uint32_t l = 1; l < nv; l++) global(p, &s, l, b);
        for (uint32_t l = 1; l < nv; l += 2) distance(&s, l); /* even segments (from vertex 0, 2, ...) */
        for (uint32_t l = 2; l < nv; l += 2) distance(&s, l); /* odd segments */
        for (uint32_t l = 1; l < nv; l++) {
            const sim_lv3 before = sim_lv3_ld(s.x, l);
            collide(&s, l, sd, k);
            sim_lv3_st(s.push, l, sim_lv3_add(sim_lv3_ld(s.push, l), sim_lv3_sub(sim_lv3_ld(s.x, l), before)));
        }
    }
    if (sd->friction > 0.0f)
        for (uint32_t l = 1; l < nv; l++)
            for (int j = 0; j < W; j++) {
                float x[3] = { s.x[3 * l * W + j], s.x[(3 * l + 1) * W + j], s.x[(3 * l + 2) * W + j] };
                friction(x, ldl(s.push, l, j), ldl(s.gc, l, j), sd->friction);
                stl(s.x, l, j, ld(x));
            }
    sim_lane worst, sum;
    close_lengths(sd, k, &s, nv, &worst, &sum);
    for (int j = 0; j < W && s0 + (uint32_t)j < p->ns; j++) {
        if (worst[j] > p->stretch_per_worker[worker]) p->stretch_per_worker[worker] = worst[j];
        const float c = sum[j] < (float)SIM_PBD_STRETCH_CAP ? sum[j] : (float)SIM_PBD_STRETCH_CAP;
        p->stretch_sum_per_worker[worker] += (uint32_t)(c * (float)SIM_PBD_STRETCH_UNIT);
    }
    for (int j = 0; j < W && s0 + (uint32_t)j < p->ns; j++) {
        const uint32_t si = s0 + (uint32_t)j;
        float *x = p->x + 3 * (size_t)si * nv, *v = p->v + 3 * (size_t)si * nv;
        float bad = 0.0f;
        for (uint32_t l = 0; l < nv; l++) {
            const core_vec3 xl = ldl(s.x, l, j), vl = ldl(s.v, l, j);
            st(x + 3 * l, xl);
            st(v + 3 * l, vl);
            if (l > 0) bad += (vl.x - vl.x) + (vl.y - vl.y) + (vl.z - vl.z);
            bad += (xl.x - xl.x) + (xl.y - xl.y) + (xl.z - xl.z);
        }
        if (bad != 0.0f) { /* NaN or inf somewhere along the strand */
            sim_pbd_restore_strand(p, si, head);
            p->nan_per_worker[worker]++;
        }
    }
}

typedef struct substep_ctx {
    sim_pbd *p;
    int k;
} substep_ctx;

/* One task = SIM_CHUNK strands (a multiple of SIM_PBD_LANES); strands are independent, so
 * results do not depend on the thread count. */
static void substep_task(void *vctx, size_t task, size_t ntasks, int worker)
{
    (void)ntasks;
    const substep_ctx *c = vctx;
    const uint32_t s0 = (uint32_t)(task * SIM_CHUNK), s1 = s0 + SIM_CHUNK < c->p->ns ? s0 + SIM_CHUNK : c->p->ns;
    for (uint32_t s = s0; s < s1; s += W) group_substep(c->p, c->k, s, worker);
}

void sim_pbd_substep(sim_pbd *p, int k)
{
    substep_ctx c = { p, k };
    sim_pool_run_tasks(&p->pool, substep_task, &c, (p->ns + SIM_CHUNK - 1) / SIM_CHUNK);
}
