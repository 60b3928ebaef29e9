/* proto: the groom data binary served at /groom.bin (rest lengths and roots; write, check). */
#include <math.h>
#include <string.h>

#include "proto.h"
#include "proto_bin.h"

size_t proto_groom_bin_size(const core_groom *g) { return PROTO_GROOM_HEADER + 16u * (size_t)g->nstrands; }

void proto_groom_bin_write(const core_groom *g, unsigned char *out)
{
    size_t ns = g->nstrands, nv = g->nverts;
    memcpy(out, PROTO_GROOM_MAGIC, 4);
    proto_bin_put_u32(out + 4, PROTO_GROOM_VERSION);
    proto_bin_put_u32(out + 8, g->nstrands);
    proto_bin_put_u32(out + 12, g->nverts);
    unsigned char *lens = out + PROTO_GROOM_HEADER, *roots = lens + 4 * ns;
    for (size_t s = 0; s < ns; s++) {
        const float *p = g->pos + 3 * s * nv;
        double len = 0.0;
        for (size_t v = 1; v < nv; v++) {
            double dx = p[3 * v] - p[3 * v - 3], dy = p[3 * v + 1] - p[3 * v - 2], dz = p[3 * v + 2] - p[3 * v - 1];
            len += sqrt(dx * dx + dy * dy + dz * dz);
        }
        proto_bin_put_f32(lens + 4 * s, nv > 1 ? (float)(len / (double)(nv - 1)) : 0.0f);
        for (int k = 0; k < 3; k++) proto_bin_put_f32(roots + 12 * s + 4 * (size_t)k, p[k]);
    }
}

core_status proto_groom_bin_read(const unsigned char *bin, size_t len, uint32_t *nstrands, uint32_t *nverts, core_err *err)
{
    *nstrands = *nverts = 0;
    uint32_t ns, nv;
    core_status st = proto_bin_header(bin, len, PROTO_GROOM_MAGIC, PROTO_GROOM_VERSION, "groom data binary", &ns, &nv, err);
    if (st != CORE_OK) return st;
    if (ns < 1 || nv < 2)
        return core_fail(err, CORE_EFORMAT, "groom data binary: %u strands of %u vertices (at least 1 of 2 expected)", ns, nv);
    uint64_t want = PROTO_GROOM_HEADER + 16ull * ns;
    if (want != len)
        return core_fail(err, CORE_EFORMAT, "groom data binary: %u strands need %llu bytes, got %zu", ns,
                         (unsigned long long)want, len);
    const unsigned char *p = bin + PROTO_GROOM_HEADER;
    for (uint32_t s = 0; s < ns; s++, p += 4) {
        float f = proto_bin_get_f32(p);
        if (!isfinite(f) || f < 0.0f)
            return core_fail(err, CORE_EFORMAT, "groom data binary: strand %u's rest length is not a finite length", s);
    }
    for (size_t i = 0; i < 3u * (size_t)ns; i++, p += 4)
        if (!isfinite(proto_bin_get_f32(p)))
            return core_fail(err, CORE_EFORMAT, "groom data binary: strand %zu's root is not finite", i / 3);
    *nstrands = ns;
    *nverts = nv;
    return CORE_OK;
}
