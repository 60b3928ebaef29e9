/* groom: validation of collision meshes (coordinates, indices, closed manifold, orientation). */
#include "groom.h"

#include <math.h>
#include <stdlib.h>

/* One directed triangle edge keyed by its undirected vertex pair. */
typedef struct edge_ref {
    uint64_t key; /* min vertex << 32 | max vertex */
    uint32_t tri;
    uint32_t fwd; /* 1 when the triangle walks it from the lower to the higher index */
} edge_ref;

static int cmp_edge(const void *a, const void *b)
{
    const edge_ref *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return x->tri < y->tri ? -1 : x->tri > y->tri;
}

static core_status check_edges(const core_mesh *m, core_err *err)
{
    size_t n = (size_t)m->ntris * 3;
    edge_ref *e = malloc(n * sizeof *e);
    if (!e) return core_fail(err, CORE_ENOMEM, "mesh: out of memory checking %u triangles", m->ntris);
    for (uint32_t t = 0; t < m->ntris; t++)
        for (uint32_t c = 0; c < 3; c++) {
            uint32_t a = m->tri[3 * t + c], b = m->tri[3 * t + (c + 1) % 3];
            edge_ref *r = &e[3 * (size_t)t + c];
            r->key = a < b ? (uint64_t)a << 32 | b : (uint64_t)b << 32 | a;
            r->tri = t;
            r->fwd = a < b;
        }
    qsort(e, n, sizeof *e, cmp_edge);
    core_status st = CORE_OK;
    for (size_t i = 0; i < n && st == CORE_OK;) {
        size_t j = i + 1;
        while (j < n && e[j].key == e[i].key) j++;
        uint32_t lo = (uint32_t)(e[i].key >> 32), hi = (uint32_t)e[i].key;
        if (j - i == 1)
            st = core_fail(err, CORE_EFORMAT,
                           "mesh is not closed: edge %u-%u of triangle %u belongs to no other triangle", lo, hi,
                           e[i].tri);
        else if (j - i > 2)
            st = core_fail(err, CORE_EFORMAT,
                           "mesh is not manifold: edge %u-%u is shared by %zu triangles (%u, %u, %u%s)", lo, hi, j - i,
                           e[i].tri, e[i + 1].tri, e[i + 2].tri, j - i > 3 ? ", ..." : "");
        else if (e[i].fwd == e[i + 1].fwd)
            st = core_fail(err, CORE_EFORMAT,
                           "mesh has inconsistent orientation: triangles %u and %u both run edge %u->%u in the same "
                           "direction",
                           e[i].tri, e[i + 1].tri, e[i].fwd ? lo : hi, e[i].fwd ? hi : lo);
        i = j;
    }
    free(e);
    return st;
}

core_status groom_mesh_check(const core_mesh *m, core_err *err)
{
    if (!m || m->nverts == 0 || m->ntris == 0 || !m->pos || !m->tri)
        return core_fail(err, CORE_EFORMAT, "mesh is empty (%u vertices, %u triangles)", m ? m->nverts : 0,
                         m ? m->ntris : 0);
    if (m->nverts > GROOM_MESH_MAX_VERTS)
        return core_fail(err, CORE_EFORMAT, "mesh has %u vertices, more than %u", m->nverts, GROOM_MESH_MAX_VERTS);
    if (m->ntris > GROOM_MESH_MAX_TRIS)
        return core_fail(err, CORE_EFORMAT, "mesh has %u triangles, more than %u", m->ntris, GROOM_MESH_MAX_TRIS);
    for (uint32_t v = 0; v < m->nverts; v++)
        for (uint32_t c = 0; c < 3; c++) {
            float x = m->pos[3 * v + c];
            if (!isfinite(x) || fabsf(x) > GROOM_MESH_MAX_COORD)
                return core_fail(err, CORE_EFORMAT, "mesh vertex %u: coordinate %g is not finite or beyond %g m", v,
                                 (double)x, (double)GROOM_MESH_MAX_COORD);
        }
    for (uint32_t t = 0; t < m->ntris; t++) {
        const uint32_t *i = &m->tri[3 * t];
        for (uint32_t c = 0; c < 3; c++)
            if (i[c] >= m->nverts)
                return core_fail(err, CORE_EFORMAT, "mesh triangle %u: vertex index %u out of range (%u vertices)", t,
                                 i[c], m->nverts);
        if (i[0] == i[1] || i[1] == i[2] || i[0] == i[2])
            return core_fail(err, CORE_EFORMAT, "mesh triangle %u is degenerate (vertices %u %u %u)", t, i[0], i[1],
                             i[2]);
    }
    core_status st = check_edges(m, err);
    if (st != CORE_OK) return st;
    double vol = 0.0; /* 6 x signed volume, relative to the first vertex */
    const float *o = m->pos;
    for (uint32_t t = 0; t < m->ntris; t++) {
        const float *a = &m->pos[3 * m->tri[3 * t]], *b = &m->pos[3 * m->tri[3 * t + 1]],
                    *c = &m->pos[3 * m->tri[3 * t + 2]];
        double ax = a[0] - o[0], ay = a[1] - o[1], az = a[2] - o[2];
        double bx = b[0] - o[0], by = b[1] - o[1], bz = b[2] - o[2];
        double cx = c[0] - o[0], cy = c[1] - o[1], cz = c[2] - o[2];
        vol += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
    }
    if (!(vol > 0.0))
        return core_fail(err, CORE_EFORMAT,
                         "mesh encloses a volume of %g m^3: its triangles must be counter-clockwise seen from outside",
                         vol / 6.0);
    return CORE_OK;
}
