/* sim_hm: the solver's fixed structure from the rest mesh: cloth triangles and bends, corner
 * tetrahedra, their condition rows, edges, surface, the system's block pattern. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sim_hm_internal.h"

#define VTX(h, c, l) ((c) * (h)->nlayers + (l))

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* The layer edges (unique, a < b in the key) and how many faces use each. */
typedef struct edge_list {
    uint64_t *key;
    uint8_t *uses;
    uint32_t n;
} edge_list;

static core_status layer_edges(const core_hairmesh *m, edge_list *e, core_err *err)
{
    memset(e, 0, sizeof *e);
    e->key = malloc((size_t)m->nfaces * 4 * sizeof *e->key);
    e->uses = malloc((size_t)m->nfaces * 4);
    if (!e->key || !e->uses) return core_fail(err, CORE_ENOMEM, "out of memory for the hair mesh's edges");
    size_t n = 0;
    for (uint32_t f = 0; f < m->nfaces; f++) {
        const uint32_t *c = m->faces + 4 * (size_t)f;
        uint32_t nc = c[3] == CORE_HAIRMESH_NONE ? 3 : 4;
        for (uint32_t k = 0; k < nc; k++) {
            uint32_t a = c[k], b = c[(k + 1) % nc];
            e->key[n++] = a < b ? ((uint64_t)a << 32) | b : ((uint64_t)b << 32) | a;
        }
    }
    qsort(e->key, n, sizeof *e->key, cmp_u64);
    uint32_t u = 0;
    for (size_t i = 0; i < n; i++) {
        if (u > 0 && e->key[u - 1] == e->key[i]) {
            e->uses[u - 1]++;
            continue;
        }
        e->key[u] = e->key[i];
        e->uses[u++] = 1;
    }
    e->n = u;
    return CORE_OK;
}

/* A row of the vertices v[0..nv-1] (a triangle's 4th repeats its 3rd). */
static uint32_t add_row(sim_hm_rows *r, const uint32_t *v, uint8_t nv)
{
    const uint32_t i = r->n++;
    for (int k = 0; k < 4; k++) r->v[4 * (size_t)i + k] = v[k < nv ? k : nv - 1];
    r->nv[i] = nv;
    return i;
}

/* The triangle a b c with its rest (u, v) frame (u: along, projected on its plane) and its 3 rows. */
static void add_tri(sim_hm *h, uint32_t a, uint32_t b, uint32_t c, const float along[3])
{
    sim_hm_cloth *cl = &h->cloth;
    const float *P = h->mesh.pos;
    float co[4], area;
    if (!sim_hm_bw_rest_triangle(P + 3 * (size_t)a, P + 3 * (size_t)b, P + 3 * (size_t)c, along, co, &area)) return;
    const uint32_t t = cl->ntri++, v[3] = { a, b, c };
    for (int k = 0; k < 4; k++) cl->tri_c[4 * (size_t)t + k] = co[k];
    cl->tri_a[t] = area;
    float cu[3], cv[3], mu = 0.0f, mv = 0.0f, ms = 0.0f;
    sim_hm_bw_coefficients(co, cu, cv);
    for (int i = 0; i < 3; i++)
        mu = fmaxf(mu, cu[i] * cu[i]), mv = fmaxf(mv, cv[i] * cv[i]), ms = fmaxf(ms, cu[i] * cu[i] + cv[i] * cv[i]);
    const float a2 = area * area;
    cl->tri_s[3 * t] = 1.0f / (a2 * mu), cl->tri_s[3 * t + 1] = 1.0f / (a2 * mv), cl->tri_s[3 * t + 2] = 1.0f / (a2 * ms);
    for (int k = 0; k < 3; k++) add_row(&h->rows, v, 3);
}

/* The bend between the triangles (x1, x3, x4) and (x2, x4, x3): its rest angle and scale. */
static void add_bend(sim_hm *h, uint32_t x1, uint32_t x2, uint32_t x3, uint32_t x4)
{
    sim_hm_cloth *cl = &h->cloth;
    const float *P = h->mesh.pos;
    const float *p1 = P + 3 * (size_t)x1, *p2 = P + 3 * (size_t)x2, *p3 = P + 3 * (size_t)x3, *p4 = P + 3 * (size_t)x4;
    float theta, g[12];
    if (!sim_hm_bw_bend(p1, p2, p3, p4, &theta, g)) return;
    const uint32_t b = cl->nbend++, v[4] = { x1, x2, x3, x4 };
    const float g1 = sqrtf(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]), g2 = sqrtf(g[3] * g[3] + g[4] * g[4] + g[5] * g[5]);
    cl->bend_theta0[b] = theta;
    cl->bend_scale[b] = 0.5f / (g1 * g2); /* |dtheta/dx1| = 1 / h1 */
    add_row(&h->rows, v, 4);
}

static void add_damper(sim_hm *h, uint32_t a, uint32_t b)
{
    sim_hm_dampers *d = &h->damp;
    d->a[d->n] = a, d->b[d->n++] = b;
}

static void add_tet(sim_hm *h, uint32_t v0, uint32_t v1, uint32_t v2, uint32_t v3)
{
    sim_hm_tets *t = &h->tets;
    const float *p0 = h->mesh.pos + 3 * (size_t)v0, *p1 = h->mesh.pos + 3 * (size_t)v1;
    const float *p2 = h->mesh.pos + 3 * (size_t)v2, *p3 = h->mesh.pos + 3 * (size_t)v3;
    core_vec3 e1 = core_v3(p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]);
    core_vec3 e2 = core_v3(p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]);
    core_vec3 e3 = core_v3(p3[0] - p0[0], p3[1] - p0[1], p3[2] - p0[2]);
    float vol = core_v3_dot(e1, core_v3_cross(e2, e3)) / 6.0f;
    if (!(fabsf(vol) > 1e-15f)) return; /* a degenerate rest tetrahedron has no volume to keep */
    uint32_t i = t->n++;
    const uint32_t v[4] = { v0, v1, v2, v3 };
    add_row(&h->rows, v, 4);
    t->v0[i] = vol;
    t->scale[i] = powf(fabsf(vol), 2.0f / 3.0f) / (vol * vol);
}

static core_status alloc_all(sim_hm *h, uint32_t ntri, uint32_t nbend, uint32_t ndamp, uint32_t ntet, uint32_t ned,
                             core_err *err)
{
    sim_hm_dampers *d = &h->damp;
    d->a = malloc(ndamp * sizeof *d->a), d->b = malloc(ndamp * sizeof *d->b), d->at = malloc(2 * (size_t)ndamp * sizeof *d->at);
    sim_hm_cloth *cl = &h->cloth;
    sim_hm_rows *r = &h->rows;
    const size_t nr = 3 * (size_t)ntri + nbend + ntet;
    cl->tri_c = malloc(4 * (size_t)ntri * sizeof *cl->tri_c), cl->tri_a = malloc(ntri * sizeof *cl->tri_a);
    cl->tri_b = calloc(2 * (size_t)ntri, sizeof *cl->tri_b), cl->tri_s = malloc(3 * (size_t)ntri * sizeof *cl->tri_s);
    cl->bend_theta0 = malloc(nbend * sizeof *cl->bend_theta0), cl->bend_scale = malloc(nbend * sizeof *cl->bend_scale);
    h->tets.v0 = malloc(ntet * sizeof *h->tets.v0), h->tets.scale = malloc(ntet * sizeof *h->tets.scale);
    r->v = malloc(4 * nr * sizeof *r->v), r->nv = malloc(nr), r->at = malloc(16 * nr * sizeof *r->at);
    r->g = calloc(12 * nr, sizeof *r->g), r->w = calloc(nr, sizeof *r->w);
    h->edges.row = calloc((size_t)h->n + 1, sizeof *h->edges.row), h->edges.nb = malloc(2 * (size_t)ned * sizeof *h->edges.nb);
    h->edges.inv_degree = calloc(h->n, sizeof *h->edges.inv_degree);
    h->surface = calloc(h->n, 1);
    if (!d->a || !d->b || !d->at || !cl->tri_c || !cl->tri_a || !cl->tri_b || !cl->tri_s || !cl->bend_theta0 || !cl->bend_scale || !h->tets.v0 || !h->tets.scale || !r->v ||
        !r->nv || !r->at || !r->g || !r->w || !h->edges.row || !h->edges.nb || !h->edges.inv_degree || !h->surface)
        return core_fail(err, CORE_ENOMEM, "out of memory for the hair mesh solver's structure");
    return CORE_OK;
}

/* The edge a-b: counted into row[a + 1] and row[b + 1] (pass 0), or written into both
 * neighbour lists at the cursors row[a] and row[b] (pass 1). */
static void link(sim_hm_edges *ed, int pass, uint32_t a, uint32_t b)
{
    if (pass == 0) {
        ed->n++, ed->row[a + 1]++, ed->row[b + 1]++;
        return;
    }
    ed->nb[ed->row[a]++] = b;
    ed->nb[ed->row[b]++] = a;
}

/* The deformation minimization's edges (every column's segments, every layer edge in every
 * layer) as ascending neighbour lists: degrees, then the lists with row[] as cursors, then row[]
 * back, then each list sorted. */
static void mesh_edges(sim_hm *h, const edge_list *e)
{
    sim_hm_edges *ed = &h->edges;
    const uint32_t nl = h->nlayers, nc = h->ncols;
    for (int pass = 0; pass < 2; pass++) {
        for (uint32_t c = 0; c < nc; c++)
            for (uint32_t l = 0; l + 1 < nl; l++) link(ed, pass, VTX(h, c, l), VTX(h, c, l + 1));
        for (uint32_t k = 0; k < e->n; k++) {
            const uint32_t a = (uint32_t)(e->key[k] >> 32), b = (uint32_t)(e->key[k] & 0xffffffffu);
            for (uint32_t l = 0; l < nl; l++) link(ed, pass, VTX(h, a, l), VTX(h, b, l));
        }
        if (pass == 0)
            for (uint32_t i = 0; i < h->n; i++) {
                const uint32_t d = ed->row[i + 1];
                ed->inv_degree[i] = d > 0 ? 1.0f / (float)d : 0.0f;
                ed->row[i + 1] += ed->row[i];
            }
    }
    for (uint32_t i = h->n; i > 0; i--) ed->row[i] = ed->row[i - 1];
    ed->row[0] = 0;
    for (uint32_t i = 0; i < h->n; i++) /* ascending (insertion sort: a few neighbours each) */
        for (uint32_t k = ed->row[i] + 1; k < ed->row[i + 1]; k++)
            for (uint32_t j = k; j > ed->row[i] && ed->nb[j - 1] > ed->nb[j]; j--) {
                const uint32_t t = ed->nb[j];
                ed->nb[j] = ed->nb[j - 1], ed->nb[j - 1] = t;
            }
}

/* The side quad of the layer edge a-b between layers l and l + 1 as the triangles (a_l, b_l, b_l+1)
 * and (a_l, b_l+1, a_l+1), u along the hair (the quad's mean column direction). */
static void side_quad(sim_hm *h, uint32_t a, uint32_t b, uint32_t l)
{
    const float *P = h->mesh.pos;
    const uint32_t a0 = VTX(h, a, l), b0 = VTX(h, b, l), a1 = VTX(h, a, l + 1), b1 = VTX(h, b, l + 1);
    float along[3];
    for (int k = 0; k < 3; k++) along[k] = P[3 * a1 + k] - P[3 * a0 + k] + P[3 * b1 + k] - P[3 * b0 + k];
    add_tri(h, a0, b0, b1, along);
    add_tri(h, a0, b1, a1, along);
}

/* The bends of the side quads of the layer edge a-b at layer l: across the diagonal a_l b_l+1,
 * and across the upper edge a_l+1 b_l+1 with the quad above. */
static void side_bends(sim_hm *h, uint32_t a, uint32_t b, uint32_t l)
{
    const uint32_t a0 = VTX(h, a, l), b0 = VTX(h, b, l), a1 = VTX(h, a, l + 1), b1 = VTX(h, b, l + 1);
    add_bend(h, b0, a1, a0, b1);
    if (l + 2 < h->nlayers) add_bend(h, a0, VTX(h, b, l + 2), b1, a1);
}

core_status sim_hm_build(sim_hm *h, core_err *err)
{
    const core_hairmesh *m = &h->mesh;
    const uint32_t nl = h->nlayers, nc = h->ncols;
    edge_list e;
    core_status st = layer_edges(m, &e, err);
    uint32_t nquads = 0;
    for (uint32_t f = 0; f < m->nfaces; f++) nquads += m->faces[4 * (size_t)f + 3] != CORE_HAIRMESH_NONE;
    const uint32_t ntri = 2 * e.n * (nl - 1) + (m->nfaces + nquads) * (nl - 1);
    const uint32_t nbend = e.n * (2 * (nl - 1) - 1);
    const uint32_t ndamp = nc * (nl - 1) + nc * (nl - 2) + 3 * e.n * (nl - 1) + 2 * nquads * (nl - 1);
    const uint32_t ntet = 8 * m->nfaces * (nl - 1);
    const uint32_t ned = nc * (nl - 1) + e.n * nl;
    if (st == CORE_OK) st = alloc_all(h, ntri, nbend, ndamp, ntet, ned, err);
    if (st != CORE_OK) {
        free(e.key);
        free(e.uses);
        return st;
    }
    for (uint32_t c = 0; c < nc; c++)
        for (uint32_t l = 0; l + 1 < nl; l++) {
            add_damper(h, VTX(h, c, l + 1), VTX(h, c, l));
            if (l + 2 < nl) add_damper(h, VTX(h, c, l + 2), VTX(h, c, l));
        }
    for (uint32_t k = 0; k < e.n; k++) {
        uint32_t a = (uint32_t)(e.key[k] >> 32), b = (uint32_t)(e.key[k] & 0xffffffffu);
        for (uint32_t l = 0; l + 1 < nl; l++) {
            side_quad(h, a, b, l);
            add_damper(h, VTX(h, a, l + 1), VTX(h, b, l + 1));
            add_damper(h, VTX(h, a, l + 1), VTX(h, b, l));
            add_damper(h, VTX(h, b, l + 1), VTX(h, a, l));
        }
        if (e.uses[k] == 1)
            for (uint32_t l = 1; l < nl; l++) h->surface[VTX(h, a, l)] = h->surface[VTX(h, b, l)] = 1;
    }
    const float *P = m->pos;
    for (uint32_t f = 0; f < m->nfaces; f++) { /* the layer faces above the roots, u along the first edge */
        const uint32_t *c = m->faces + 4 * (size_t)f;
        for (uint32_t l = 1; l < nl; l++) {
            const uint32_t v0 = VTX(h, c[0], l), v1 = VTX(h, c[1], l), v2 = VTX(h, c[2], l);
            float along[3];
            for (int k = 0; k < 3; k++) along[k] = P[3 * v1 + k] - P[3 * v0 + k];
            add_tri(h, v0, v1, v2, along);
            if (c[3] == CORE_HAIRMESH_NONE) continue;
            add_tri(h, v0, v2, VTX(h, c[3], l), along);
            add_damper(h, v0, v2);
            add_damper(h, v1, VTX(h, c[3], l));
        }
    }
    h->rows.bend0 = h->rows.n;
    for (uint32_t k = 0; k < e.n; k++)
        for (uint32_t l = 0; l + 1 < nl; l++) side_bends(h, (uint32_t)(e.key[k] >> 32), (uint32_t)(e.key[k] & 0xffffffffu), l);
    h->rows.tet0 = h->rows.n;
    for (uint32_t c = 0; c < nc; c++) h->surface[VTX(h, c, nl - 1)] = 1;
    for (uint32_t f = 0; f < m->nfaces; f++) {
        const uint32_t *c = m->faces + 4 * (size_t)f;
        uint32_t ncor = c[3] == CORE_HAIRMESH_NONE ? 3 : 4;
        for (uint32_t l = 0; l + 1 < nl; l++)
            for (uint32_t k = 0; k < ncor; k++) {
                uint32_t cn = c[(k + 1) % ncor], cp = c[(k + ncor - 1) % ncor];
                add_tet(h, VTX(h, c[k], l), VTX(h, cn, l), VTX(h, cp, l), VTX(h, c[k], l + 1));
                add_tet(h, VTX(h, c[k], l + 1), VTX(h, cp, l + 1), VTX(h, cn, l + 1), VTX(h, c[k], l));
            }
    }
    mesh_edges(h, &e);
    free(e.key);
    free(e.uses);
    return sim_hm_bsr_build(h, err);
}

void sim_hm_build_free(sim_hm *h)
{
    sim_hm_cloth *cl = &h->cloth;
    sim_hm_rows *r = &h->rows;
    free(h->damp.a), free(h->damp.b), free(h->damp.at);
    memset(&h->damp, 0, sizeof h->damp);
    free(cl->tri_c), free(cl->tri_a), free(cl->tri_b), free(cl->tri_s), free(cl->bend_theta0), free(cl->bend_scale);
    free(h->tets.v0), free(h->tets.scale);
    free(r->v), free(r->nv), free(r->at), free(r->g), free(r->w);
    free(h->edges.row), free(h->edges.nb), free(h->edges.inv_degree);
    free(h->surface);
    sim_hm_bsr_free(&h->bsr);
    memset(cl, 0, sizeof *cl);
    memset(&h->tets, 0, sizeof h->tets);
    memset(r, 0, sizeof *r);
    memset(&h->edges, 0, sizeof h->edges);
    h->surface = NULL;
}
