/* sim: one PBD substep (thesis 3.2): Verlet prediction, then iterations of the angular and
 * global shape constraints (XPBD, compliance 1 / stiffness), the distance constraints in even
 * then odd segments and the collision constraints; velocities from the positions. */
#include <math.h>
#include <string.h>

#include "sim_pbd_internal.h"

/* Rotates v by the minimal rotation taking unit a onto unit b. */
static core_vec3 min_rotate(core_vec3 a, core_vec3 b, core_vec3 v)
{
    const core_vec3 k = core_v3_cross(a, b);
    const float co = core_v3_dot(a, b);
    const float kv = core_v3_dot(k, v) / fmaxf(1.0f + co, 1e-6f);
    return core_v3_add(core_v3_add(core_v3_scale(v, co), core_v3_cross(k, v)), core_v3_scale(k, kv));
}

static core_vec3 unit(core_vec3 a)
{
    const float l = core_v3_len(a);
    return l > 1e-15f ? core_v3_scale(a, 1.0f / l) : core_v3(0.0f, 1.0f, 0.0f);
}

static core_vec3 ld(const float *a) { return core_v3(a[0], a[1], a[2]); }
static void st(float *a, core_vec3 v) { a[0] = v.x, a[1] = v.y, a[2] = v.z; }

/* Where the rigid motion of the colliders (the head) over the substep takes p (rows m0 m1 m2 t). */
static core_vec3 carry(const float *C, core_vec3 p)
{
    return core_v3(C[0] * p.x + C[1] * p.y + C[2] * p.z + C[3], C[4] * p.x + C[5] * p.y + C[6] * p.z + C[7],
                   C[8] * p.x + C[9] * p.y + C[10] * p.z + C[11]);
}

/* One XPBD projection of the vector constraint x - t = 0 (t carried by a parent vertex xp of
 * inverse mass wp, NULL when the target is fixed; x has inverse mass 1) with compliance 1 / k
 * (k per unit mass, 1/s^2) and its stiffness-proportional damper k b acting on x - xc (xc: the
 * vertex's start carried by the target's frame), multiplier lam (3 floats). In terms of
 * w = k h^2 and c = k h b the first projection on a fixed target moves x by
 * (w (t - x) + c (xc - x)) / (1 + w + c), the implicit step of the DFTL solver's springs; the
 * multiplier keeps later iterations from pulling further, so the settled offset is g / k for
 * any h and iteration count. A parent takes its share of the reaction. */
static void pull(float *x, float *xp, float wp, core_vec3 t, core_vec3 xc, float w, float c, float *lam)
{
    const float den = 1.0f + (w + c) * (1.0f + wp);
    const float tv[3] = { t.x, t.y, t.z }, cv[3] = { xc.x, xc.y, xc.z };
    for (int d = 0; d < 3; d++) {
        const float dl = (w * (tv[d] - x[d]) - c * (x[d] - cv[d]) - lam[d]) / den;
        lam[d] += dl;
        x[d] += dl;
        if (xp) xp[d] -= wp * dl;
    }
}

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

/* Pushes point x out of the distance grid placed by ws, to SIM_SDF_SKIN above its surface. */
static void push_sdf(const core_sdf *sdf, const sim_wsdf *ws, float *x)
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
    const float push = (float)SIM_SDF_SKIN - core_sdf_sample(sdf, q, &g);
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

typedef struct strand_view {
    float *x, *v, *o, *lg, *ll, *push;
    const float *r, *len;
} strand_view;

/* The angular constraint of level l >= 1: toward its rest segment turned by the minimal rotation
 * of its parent segment from rest (under the head) to now; at level 1 the head's frame. Reads
 * level l-2 and writes l and its parent l-1 (which takes the reaction), so the levels of one
 * residue mod 3 touch disjoint vertices and can be solved in parallel. Its damper acts on the
 * motion relative to the start carried by the same frame. */
static void angular(const sim_pbd *p, const strand_view *s, uint32_t l, int k, float b)
{
    const float kl = p->kl[l];
    if (!(kl > 0.0f)) return;
    const float h = p->step.h, w = kl * h * h, c = kl * h * b;
    const core_quat hr = p->step.head[k].rot;
    const float *x = s->x, *o = s->o, *r = s->r;
    const core_vec3 seg = core_q_rotate(hr, core_v3_sub(ld(r + 3 * l), ld(r + 3 * (l - 1))));
    const core_vec3 parent = ld(x + 3 * (l - 1));
    core_vec3 t, xc;
    if (l == 1) {
        t = core_v3_add(parent, seg);
        xc = carry(p->step.carry[k], ld(o + 3));
    } else {
        const core_vec3 e0 = unit(core_q_rotate(hr, core_v3_sub(ld(r + 3 * (l - 1)), ld(r + 3 * (l - 2)))));
        const core_vec3 e1 = unit(core_v3_sub(parent, ld(x + 3 * (l - 2))));
        const core_vec3 eo = unit(core_v3_sub(ld(o + 3 * (l - 1)), ld(o + 3 * (l - 2))));
        t = core_v3_add(parent, min_rotate(e0, e1, seg));
        xc = core_v3_add(parent, min_rotate(eo, e1, core_v3_sub(ld(o + 3 * l), ld(o + 3 * (l - 1)))));
    }
    pull(s->x + 3 * l, s->x + 3 * (l - 1), l == 1 ? 0.0f : 1.0f, t, xc, w, c, s->ll + 3 * l);
}

/* The distance constraint of the segment ending at level l (the root does not move). */
static void distance(const strand_view *s, uint32_t l)
{
    float *a = s->x + 3 * (l - 1), *b = s->x + 3 * l;
    const core_vec3 d = core_v3_sub(ld(b), ld(a));
    const float dl = core_v3_len(d);
    if (!(dl > 1e-12f)) return;
    const float wa = l == 1 ? 0.0f : 0.5f, wb = 1.0f - wa;
    const core_vec3 n = core_v3_scale(d, (dl - s->len[l]) / dl);
    st(a, core_v3_add(ld(a), core_v3_scale(n, wa)));
    st(b, core_v3_sub(ld(b), core_v3_scale(n, wb)));
}

static void strand_substep(sim_pbd *p, int k, uint32_t si, uint64_t *nan)
{
    const sim_step_desc *sd = &p->step;
    const uint32_t nv = p->nv;
    const size_t base = 3 * (size_t)si * nv;
    const strand_view s = { p->x + base,  p->v + base,    p->start + base,           p->lg + base,
                            p->ll + base, p->push + base, p->rest + base, p->len + (size_t)si * nv };
    const float h = sd->h, inv_h = sd->inv_h, b = 0.5f * fmaxf((float)SIM_SHAPE_DAMPING_STEP - h, 0.0f);
    const core_xform head = sd->head[k];
    const core_vec3 acc = ld(sd->accel);
    /* the root follows the head; the others: Verlet with air drag */
    const core_vec3 root = core_xform_point(head, ld(s.r));
    memcpy(s.o, s.x, 3 * nv * sizeof(float));
    st(s.v, core_v3_scale(core_v3_sub(root, ld(s.x)), inv_h));
    st(s.x, root);
    for (uint32_t l = 1; l < nv; l++) {
        float *x = s.x + 3 * l;
        const core_vec3 v = core_v3_scale(ld(s.v + 3 * l), sd->drag_keep);
        st(x, core_v3_add(ld(x), core_v3_add(core_v3_scale(v, h), core_v3_scale(acc, h * h))));
    }
    memset(s.lg, 0, 3 * nv * sizeof(float));
    memset(s.ll, 0, 3 * nv * sizeof(float));
    memset(s.push, 0, 3 * nv * sizeof(float));
    const sim_wcollider *wc = sd->col[k];
    const bool sdf = sd->sdf != NULL;
    for (int it = 0; it < p->params.pbd_iterations; it++) {
        for (uint32_t phase = 0; phase < 3; phase++)
            for (uint32_t l = 1 + phase; l < nv; l += 3) angular(p, &s, l, k, b);
        for (uint32_t l = 1; l < nv; l++) {
            const float kg = p->kg[l];
            if (!(kg > 0.0f)) continue;
            pull(s.x + 3 * l, NULL, 0.0f, core_xform_point(head, ld(s.r + 3 * l)), carry(sd->carry[k], ld(s.o + 3 * l)),
                 kg * h * h, kg * h * b, s.lg + 3 * l);
        }
        for (uint32_t l = 1; l < nv; l += 2) distance(&s, l); /* even segments (from vertex 0, 2, ...) */
        for (uint32_t l = 2; l < nv; l += 2) distance(&s, l); /* odd segments */
        for (uint32_t l = 1; l < nv; l++) {
            float *x = s.x + 3 * l;
            const core_vec3 before = ld(x);
            for (uint32_t c = 0; c < sd->ncolliders; c++) push_collider(&wc[c], x);
            if (sdf) push_sdf(sd->sdf, &sd->wsdf[k], x);
            st(s.push + 3 * l, core_v3_add(ld(s.push + 3 * l), core_v3_sub(ld(x), before)));
        }
    }
    if (sd->friction > 0.0f)
        for (uint32_t l = 1; l < nv; l++) friction(s.x + 3 * l, ld(s.push + 3 * l), carry(sd->carry[k], ld(s.o + 3 * l)), sd->friction);
    /* velocities from the positions; internal damping keeps a share of each vertex's velocity
     * relative to its parent's final one */
    float bad = 0.0f;
    for (uint32_t l = 1; l < nv; l++) {
        const core_vec3 vn = core_v3_scale(core_v3_sub(ld(s.x + 3 * l), ld(s.o + 3 * l)), inv_h);
        const core_vec3 pv = ld(s.v + 3 * (l - 1));
        const core_vec3 v = core_v3_add(pv, core_v3_scale(core_v3_sub(vn, pv), sd->keep));
        st(s.v + 3 * l, v);
        bad += (v.x - v.x) + (v.y - v.y) + (v.z - v.z);
    }
    for (uint32_t l = 0; l < nv; l++) bad += (s.x[3 * l] - s.x[3 * l]) + (s.x[3 * l + 1] - s.x[3 * l + 1]) + (s.x[3 * l + 2] - s.x[3 * l + 2]);
    if (bad != 0.0f) { /* NaN or inf somewhere along the strand */
        sim_pbd_restore_strand(p, si, head);
        (*nan)++;
    }
}

typedef struct substep_ctx {
    sim_pbd *p;
    int k;
} substep_ctx;

/* One task = SIM_CHUNK strands; strands are independent, so results do not depend on the
 * thread count. */
static void substep_task(void *vctx, size_t task, size_t ntasks, int worker)
{
    (void)ntasks;
    const substep_ctx *c = vctx;
    const uint32_t s0 = (uint32_t)(task * SIM_CHUNK), s1 = s0 + SIM_CHUNK < c->p->ns ? s0 + SIM_CHUNK : c->p->ns;
    for (uint32_t s = s0; s < s1; s++) strand_substep(c->p, c->k, s, &c->p->nan_per_worker[worker]);
}

void sim_pbd_substep(sim_pbd *p, int k)
{
    substep_ctx c = { p, k };
    sim_pool_run_tasks(&p->pool, substep_task, &c, (p->ns + SIM_CHUNK - 1) / SIM_CHUNK);
}
