/* sim: the strand order every backend uses: roots sorted by Morton code, so that strands
 * processed together are near each other in space (collider culling, SPH locality) and all
 * backends see the same particle order. */
#include <math.h>
#include <stdlib.h>

#include "sim_order.h"

static uint32_t spread_bits(uint32_t v) /* 10 bits -> every third bit */
{
    v &= 0x3ff;
    v = (v | (v << 16)) & 0x030000ff;
    v = (v | (v << 8)) & 0x0300f00f;
    v = (v | (v << 4)) & 0x030c30c3;
    v = (v | (v << 2)) & 0x09249249;
    return v;
}

typedef struct order_key {
    uint32_t code, strand;
} order_key;

static int key_cmp(const void *a, const void *b)
{
    const order_key *x = a, *y = b;
    if (x->code != y->code) return x->code < y->code ? -1 : 1;
    return x->strand < y->strand ? -1 : x->strand > y->strand;
}

core_status sim_strand_order(const core_groom *g, uint32_t **out, core_err *err)
{
    *out = NULL;
    uint32_t *perm = malloc(g->nstrands * sizeof *perm);
    order_key *keys = malloc(g->nstrands * sizeof *keys);
    if (!perm || !keys) {
        free(perm);
        free(keys);
        return core_fail(err, CORE_ENOMEM, "out of memory ordering %u strands", g->nstrands);
    }
    float lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (uint32_t s = 0; s < g->nstrands; s++)
        for (int k = 0; k < 3; k++) {
            float v = g->pos[3 * (size_t)s * g->nverts + k];
            lo[k] = fminf(lo[k], v), hi[k] = fmaxf(hi[k], v);
        }
    for (uint32_t s = 0; s < g->nstrands; s++) {
        uint32_t code = 0;
        for (int k = 0; k < 3; k++) {
            float ext = hi[k] - lo[k];
            float f = ext > 0.0f ? (g->pos[3 * (size_t)s * g->nverts + k] - lo[k]) / ext : 0.0f;
            code |= spread_bits((uint32_t)(f * 1023.0f)) << k;
        }
        keys[s].code = code;
        keys[s].strand = s;
    }
    qsort(keys, g->nstrands, sizeof *keys, key_cmp);
    for (uint32_t s = 0; s < g->nstrands; s++) perm[s] = keys[s].strand;
    free(keys);
    *out = perm;
    return CORE_OK;
}
