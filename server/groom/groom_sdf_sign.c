/* groom: inside/outside of distance-grid samples by the mesh's winding number along grid lines. */
#include "groom.h"
#include "groom_internal.h"

#include <math.h>

/* Side of the projected point (py, pz) of the directed edge a->b in the yz plane: +1 left,
 * -1 right. Computed from the lower vertex index to the higher one and negated for the other
 * direction, so the two triangles sharing an edge always see exactly opposite sides; a point
 * on the edge's line is moved off it by the perturbation (py + e, pz + e^2). */
static int edge_side(const float *pos, uint32_t a, uint32_t b, double py, double pz)
{
    int flip = a > b;
    if (flip) {
        uint32_t t = a;
        a = b;
        b = t;
    }
    const float *A = pos + 3 * (size_t)a, *B = pos + 3 * (size_t)b;
    double du = (double)B[1] - (double)A[1], dv = (double)B[2] - (double)A[2];
    double o = du * (pz - (double)A[2]) - dv * (py - (double)A[1]);
    int s = o > 0.0 ? 1 : o < 0.0 ? -1 : dv != 0.0 ? (dv < 0.0 ? 1 : -1) : (du > 0.0 ? 1 : -1);
    return flip ? -s : s;
}

void groom_sdf_winding(const core_mesh *m, const core_sdf *g, int16_t *wind)
{
    uint32_t nx = g->dims[0], ny = g->dims[1], nz = g->dims[2];
    size_t n = (size_t)nx * ny * nz;
    for (size_t i = 0; i < n; i++) wind[i] = 0;
    float oy = g->origin.y, oz = g->origin.z, cell = g->cell;
    for (uint32_t t = 0; t < m->ntris; t++) {
        const uint32_t *v = m->tri + 3 * (size_t)t;
        const float *A = m->pos + 3 * (size_t)v[0], *B = m->pos + 3 * (size_t)v[1], *C = m->pos + 3 * (size_t)v[2];
        /* grid lines through the triangle's yz box (one extra each side; the edge test decides) */
        float ylo = fminf(A[1], fminf(B[1], C[1])), yhi = fmaxf(A[1], fmaxf(B[1], C[1]));
        float zlo = fminf(A[2], fminf(B[2], C[2])), zhi = fmaxf(A[2], fmaxf(B[2], C[2]));
        float j0f = floorf((ylo - oy) / cell) - 1.0f, j1f = ceilf((yhi - oy) / cell) + 1.0f;
        float k0f = floorf((zlo - oz) / cell) - 1.0f, k1f = ceilf((zhi - oz) / cell) + 1.0f;
        if (j1f < 0.0f || k1f < 0.0f || j0f > (float)(ny - 1) || k0f > (float)(nz - 1)) continue;
        uint32_t j0 = (uint32_t)fmaxf(j0f, 0.0f), j1 = (uint32_t)fminf(j1f, (float)(ny - 1));
        uint32_t k0 = (uint32_t)fmaxf(k0f, 0.0f), k1 = (uint32_t)fminf(k1f, (float)(nz - 1));
        /* plane: N . (p - A) = 0 */
        double e1[3] = { (double)B[0] - A[0], (double)B[1] - A[1], (double)B[2] - A[2] };
        double e2[3] = { (double)C[0] - A[0], (double)C[1] - A[1], (double)C[2] - A[2] };
        double N[3] = { e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0] };
        if (N[0] == 0.0) continue; /* edge-on to the lines: no crossing */
        int16_t s = N[0] > 0.0 ? 1 : -1;
        for (uint32_t k = k0; k <= k1; k++) {
            double pz = (double)(oz + (float)k * cell);
            for (uint32_t j = j0; j <= j1; j++) {
                double py = (double)(oy + (float)j * cell);
                int s0 = edge_side(m->pos, v[0], v[1], py, pz);
                if (edge_side(m->pos, v[1], v[2], py, pz) != s0 || edge_side(m->pos, v[2], v[0], py, pz) != s0)
                    continue;
                double x = A[0] - (N[1] * (py - A[1]) + N[2] * (pz - A[2])) / N[0];
                /* first sample strictly after the crossing */
                float u = (float)((x - (double)g->origin.x) / (double)cell);
                u = fminf(fmaxf(u, -1.0f), (float)nx);
                uint32_t i = (uint32_t)(floorf(u) + 1.0f);
                if (i < nx) wind[((size_t)k * ny + j) * nx + i] += s;
            }
        }
    }
    for (size_t line = 0; line < (size_t)ny * nz; line++) {
        int16_t *w = wind + line * nx, acc = 0;
        for (uint32_t i = 0; i < nx; i++) {
            acc += w[i];
            w[i] = acc;
        }
    }
}
