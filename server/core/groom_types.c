/* core: allocation, release and deep copies of core_groom. */
#include "groom_types.h"

#include <stdlib.h>
#include <string.h>

core_status core_groom_alloc(core_groom *g, uint32_t nstrands, uint32_t nverts, core_err *err)
{
    memset(g, 0, sizeof *g);
    if (nstrands == 0 || nverts < 2)
        return core_fail(err, CORE_EINVAL, "groom needs at least 1 strand and 2 vertices per strand (got %u x %u)",
                         nstrands, nverts);
    size_t n, bytes;
    if (!core_mul_size(nstrands, nverts, &n) || !core_mul_size(n, 3 * sizeof(float), &bytes))
        return core_fail(err, CORE_ENOMEM, "groom of %u x %u vertices is too large", nstrands, nverts);
    g->pos = calloc(1, bytes);
    if (!g->pos) return core_fail(err, CORE_ENOMEM, "out of memory for %zu groom vertices", n);
    g->nstrands = nstrands;
    g->nverts = nverts;
    return CORE_OK;
}

void core_groom_free(core_groom *g)
{
    free(g->pos);
    if (g->mesh) core_mesh_free(g->mesh);
    if (g->sdf) core_sdf_free(g->sdf);
    if (g->hairmesh) core_hairmesh_free(g->hairmesh);
    free(g->mesh);
    free(g->sdf);
    free(g->hairmesh);
    memset(g, 0, sizeof *g);
}

core_status core_groom_copy(core_groom *dst, const core_groom *src, core_err *err)
{
    core_status st = core_groom_alloc(dst, src->nstrands, src->nverts, err);
    if (st != CORE_OK) return st;
    memcpy(dst->pos, src->pos, (size_t)src->nstrands * src->nverts * 3 * sizeof(float));
    dst->ncolliders = src->ncolliders;
    memcpy(dst->colliders, src->colliders, sizeof src->colliders);
    if (src->mesh) {
        dst->mesh = malloc(sizeof *dst->mesh);
        st = dst->mesh ? core_mesh_copy(dst->mesh, src->mesh, err)
                       : core_fail(err, CORE_ENOMEM, "out of memory copying the groom's mesh");
    }
    if (st == CORE_OK && src->sdf) {
        dst->sdf = malloc(sizeof *dst->sdf);
        st = dst->sdf ? core_sdf_copy(dst->sdf, src->sdf, err)
                      : core_fail(err, CORE_ENOMEM, "out of memory copying the groom's distance grid");
    }
    if (st == CORE_OK && src->hairmesh) {
        dst->hairmesh = malloc(sizeof *dst->hairmesh);
        st = dst->hairmesh ? core_hairmesh_copy(dst->hairmesh, src->hairmesh, err)
                           : core_fail(err, CORE_ENOMEM, "out of memory copying the groom's hair mesh");
    }
    if (st != CORE_OK) core_groom_free(dst);
    return st;
}
