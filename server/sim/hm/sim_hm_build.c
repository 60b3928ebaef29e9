/* sim_hm: the solver's fixed structure from the rest mesh: springs, corner tetrahedra, edges, surface,
 * the system's block pattern. */
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

static void add_spring(sim_hm *h, uint32_t a, uint32_t b, sim_hm_spring_kind kind)
{
    sim_hm_springs *s = &h->sp;
    const float *pa = h->mesh.pos + 3 * (size_t)a, *pb = h->mesh.pos + 3 * (size_t)b;
    float d[3] = { pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2] };
    float len = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    uint32_t i = s->n++;
    s->a[i] = a, s->b[i] = b, s->kind[i] = (uint8_t)kind, s->len[i] = len;
    float k = len > 0.0f ? 1.0f / len : 0.0f;
    s->dir[3 * i] = len > 0.0f ? d[0] * k : 0.0f;
    s->dir[3 * i + 1] = len > 0.0f ? d[1] * k : 1.0f;
    s->dir[3 * i + 2] = d[2] * k;
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
    t->v[4 * i] = v0, t->v[4 * i + 1] = v1, t->v[4 * i + 2] = v2, t->v[4 * i + 3] = v3;
    t->v0[i] = vol;
    t->scale[i] = powf(fabsf(vol), 2.0f / 3.0f) / (vol * vol);
}

static core_status alloc_all(sim_hm *h, uint32_t nsp, uint32_t ntet, uint32_t ned, core_err *err)
{
    sim_hm_springs *s = &h->sp;
    s->a = malloc(nsp * sizeof *s->a), s->b = malloc(nsp * sizeof *s->b);
    s->len = malloc(nsp * sizeof *s->len), s->kind = malloc(nsp);
    s->dir = malloc(3 * (size_t)nsp * sizeof *s->dir), s->u = malloc(3 * (size_t)nsp * sizeof *s->u);
    s->alpha = malloc(nsp * sizeof *s->alpha), s->beta = malloc(nsp * sizeof *s->beta);
    h->tets.v = malloc(4 * (size_t)ntet * sizeof *h->tets.v);
    h->tets.v0 = malloc(ntet * sizeof *h->tets.v0), h->tets.scale = malloc(ntet * sizeof *h->tets.scale);
    h->tets.g = malloc(12 * (size_t)ntet * sizeof *h->tets.g), h->tets.w = malloc(ntet * sizeof *h->tets.w);
    h->edges.row = calloc((size_t)h->n + 1, sizeof *h->edges.row), h->edges.nb = malloc(2 * (size_t)ned * sizeof *h->edges.nb);
    h->edges.inv_degree = calloc(h->n, sizeof *h->edges.inv_degree);
    h->surface = calloc(h->n, 1);
    if (!s->a || !s->b || !s->len || !s->kind || !s->dir || !s->u || !s->alpha || !s->beta || !h->tets.v ||
        !h->tets.v0 || !h->tets.g || !h->tets.w || !h->tets.scale || !h->edges.row || !h->edges.nb || !h->edges.inv_degree || !h->surface)
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

core_status sim_hm_build(sim_hm *h, core_err *err)
{
    const core_hairmesh *m = &h->mesh;
    const uint32_t nl = h->nlayers, nc = h->ncols;
    edge_list e;
    core_status st = layer_edges(m, &e, err);
    uint32_t nquads = 0;
    for (uint32_t f = 0; f < m->nfaces; f++) nquads += m->faces[4 * (size_t)f + 3] != CORE_HAIRMESH_NONE;
    uint32_t nsp = nc * (nl - 1) + nc * (nl - 2) + e.n * (nl - 1) + 2 * nquads * (nl - 1) + 2 * e.n * (nl - 1);
    uint32_t ntet = 8 * m->nfaces * (nl - 1);
    uint32_t ned = nc * (nl - 1) + e.n * nl;
    if (st == CORE_OK) st = alloc_all(h, nsp, ntet, ned, err);
    if (st != CORE_OK) {
        free(e.key);
        free(e.uses);
        return st;
    }
    for (uint32_t c = 0; c < nc; c++)
        for (uint32_t l = 0; l + 1 < nl; l++) {
            add_spring(h, VTX(h, c, l + 1), VTX(h, c, l), SIM_HM_STRETCH);
            if (l + 2 < nl) add_spring(h, VTX(h, c, l + 2), VTX(h, c, l), SIM_HM_BEND);
        }
    for (uint32_t k = 0; k < e.n; k++) {
        uint32_t a = (uint32_t)(e.key[k] >> 32), b = (uint32_t)(e.key[k] & 0xffffffffu);
        for (uint32_t l = 0; l + 1 < nl; l++) {
            add_spring(h, VTX(h, a, l + 1), VTX(h, b, l + 1), SIM_HM_STRETCH);
            add_spring(h, VTX(h, a, l + 1), VTX(h, b, l), SIM_HM_SHEAR);
            add_spring(h, VTX(h, b, l + 1), VTX(h, a, l), SIM_HM_SHEAR);
        }
        if (e.uses[k] == 1)
            for (uint32_t l = 1; l < nl; l++) h->surface[VTX(h, a, l)] = h->surface[VTX(h, b, l)] = 1;
    }
    for (uint32_t c = 0; c < nc; c++) h->surface[VTX(h, c, nl - 1)] = 1;
    for (uint32_t f = 0; f < m->nfaces; f++) {
        const uint32_t *c = m->faces + 4 * (size_t)f;
        uint32_t ncor = c[3] == CORE_HAIRMESH_NONE ? 3 : 4;
        for (uint32_t l = 0; l + 1 < nl; l++) {
            if (ncor == 4) {
                add_spring(h, VTX(h, c[0], l + 1), VTX(h, c[2], l + 1), SIM_HM_SHEAR);
                add_spring(h, VTX(h, c[1], l + 1), VTX(h, c[3], l + 1), SIM_HM_SHEAR);
            }
            for (uint32_t k = 0; k < ncor; k++) {
                uint32_t cn = c[(k + 1) % ncor], cp = c[(k + ncor - 1) % ncor];
                add_tet(h, VTX(h, c[k], l), VTX(h, cn, l), VTX(h, cp, l), VTX(h, c[k], l + 1));
                add_tet(h, VTX(h, c[k], l + 1), VTX(h, cp, l + 1), VTX(h, cn, l + 1), VTX(h, c[k], l));
            }
        }
    }
    mesh_edges(h, &e);
    free(e.key);
    free(e.uses);
    return sim_hm_bsr_build(h, err);
}

void sim_hm_build_free(sim_hm *h)
{
    sim_hm_springs *s = &h->sp;
    free(s->a), free(s->b), free(s->len), free(s->kind), free(s->dir), free(s->u), free(s->alpha), free(s->beta);
    free(h->tets.v), free(h->tets.v0), free(h->tets.scale), free(h->tets.g), free(h->tets.w);
    free(h->edges.row), free(h->edges.nb), free(h->edges.inv_degree);
    free(h->surface);
    sim_hm_bsr_free(&h->bsr);
    memset(&h->sp, 0, sizeof h->sp);
    memset(&h->tets, 0, sizeof h->tets);
    memset(&h->edges, 0, sizeof h->edges);
    h->surface = NULL;
}
