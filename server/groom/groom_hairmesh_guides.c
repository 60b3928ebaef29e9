/* groom: guide strands traced through a hair mesh (thesis 3.1) into an ordinary groom. */
#include "groom.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Strand i's coordinates in a face of nc corners (groom_from_hairmesh's rule). */
static void guide_uv(uint32_t nc, uint32_t i, float *u, float *v)
{
    double a = 0.5 + 0.7548776662466927 * i, b = 0.5 + 0.5698402909980532 * i;
    float fu = (float)(a - floor(a)), fv = (float)(b - floor(b));
    if (nc == 4) {
        *u = fu, *v = fv;
        return;
    }
    float r = sqrtf(fu);
    *u = r * (1.0f - fv), *v = r * fv;
}

core_status groom_from_hairmesh(const core_hairmesh *m, uint32_t per_face, uint32_t nverts, core_groom *out,
                                core_err *err)
{
    memset(out, 0, sizeof *out);
    core_status st = core_hairmesh_validate(m, err);
    if (st != CORE_OK) return st;
    uint64_t ns = (uint64_t)m->nfaces * per_face;
    if (per_face == 0 || nverts < 2 || nverts > GROOM_MAX_VERTS || ns > GROOM_MAX_STRANDS ||
        ns > CORE_HAIRMESH_MAX_GUIDES || ns * nverts > GROOM_MAX_TOTAL)
        return core_fail(err, CORE_EINVAL,
                         "%u guides per face x %u faces x %u vertices is outside the limits (>= 1 per face, 2..%u "
                         "vertices, <= %u strands, <= %u vertices in all)",
                         per_face, m->nfaces, nverts, GROOM_MAX_VERTS, GROOM_MAX_STRANDS, GROOM_MAX_TOTAL);
    st = core_groom_alloc(out, (uint32_t)ns, nverts, err);
    if (st != CORE_OK) return st;
    out->hairmesh = malloc(sizeof *out->hairmesh);
    if (!out->hairmesh) {
        core_groom_free(out);
        return core_fail(err, CORE_ENOMEM, "out of memory for the groom's hair mesh");
    }
    st = core_hairmesh_alloc(out->hairmesh, m->ncols, m->nlayers, m->nfaces, (uint32_t)ns, nverts, err);
    if (st != CORE_OK) {
        free(out->hairmesh);
        out->hairmesh = NULL;
        core_groom_free(out);
        return st;
    }
    core_hairmesh *h = out->hairmesh;
    memcpy(h->pos, m->pos, (size_t)m->ncols * m->nlayers * 3 * sizeof(float));
    memcpy(h->faces, m->faces, (size_t)m->nfaces * 4 * sizeof(uint32_t));
    for (uint32_t f = 0; f < m->nfaces; f++) {
        uint32_t nc = m->faces[4 * (size_t)f + 3] == CORE_HAIRMESH_NONE ? 3 : 4;
        for (uint32_t i = 0; i < per_face; i++) {
            uint32_t s = f * per_face + i;
            float u, v;
            guide_uv(nc, i, &u, &v);
            h->guide_face[s] = f;
            h->guide_uv[2 * s] = u, h->guide_uv[2 * s + 1] = v;
            float *t = h->guide_t + (size_t)s * nverts;
            core_hairmesh_even_params(h, h->pos, f, u, v, nverts, t);
            core_hairmesh_trace(h, h->pos, f, u, v, nverts, t, out->pos + 3 * (size_t)s * nverts);
        }
    }
    return CORE_OK;
}
