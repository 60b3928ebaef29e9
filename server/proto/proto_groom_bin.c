/* proto: the groom data binary served at /groom.bin (rest lengths and roots; write, check). */
#include <math.h>
#include <string.h>

#include "proto.h"

static void put_u32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i));
}

static uint32_t get_u32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void put_f32(unsigned char *p, float f)
{
    uint32_t bits;
    memcpy(&bits, &f, 4);
    put_u32(p, bits);
}

static float get_f32(const unsigned char *p)
{
    uint32_t bits = get_u32(p);
    float f;
    memcpy(&f, &bits, 4);
    return f;
}

size_t proto_groom_bin_size(const core_groom *g) { return PROTO_GROOM_HEADER + 16u * (size_t)g->nstrands; }

void proto_groom_bin_write(const core_groom *g, unsigned char *out)
{
    size_t ns = g->nstrands, nv = g->nverts;
    memcpy(out, PROTO_GROOM_MAGIC, 4);
    put_u32(out + 4, PROTO_GROOM_VERSION);
    put_u32(out + 8, g->nstrands);
    put_u32(out + 12, g->nverts);
    unsigned char *lens = out + PROTO_GROOM_HEADER, *roots = lens + 4 * ns;
    for (size_t s = 0; s < ns; s++) {
        const float *p = g->pos + 3 * s * nv;
        double len = 0.0;
        for (size_t v = 1; v < nv; v++) {
            double dx = p[3 * v] - p[3 * v - 3], dy = p[3 * v + 1] - p[3 * v - 2], dz = p[3 * v + 2] - p[3 * v - 1];
            len += sqrt(dx * dx + dy * dy + dz * dz);
        }
        put_f32(lens + 4 * s, nv > 1 ? (float)(len / (double)(nv - 1)) : 0.0f);
        for (int k = 0; k < 3; k++) put_f32(roots + 12 * s + 4 * (size_t)k, p[k]);
    }
}

core_status proto_groom_bin_read(const unsigned char *bin, size_t len, uint32_t *nstrands, uint32_t *nverts, core_err *err)
{
    *nstrands = *nverts = 0;
    if (len < PROTO_GROOM_HEADER || memcmp(bin, PROTO_GROOM_MAGIC, 4) != 0)
        return core_fail(err, CORE_EFORMAT, "groom data binary: %zu bytes without the \"%s\" header", len, PROTO_GROOM_MAGIC);
    uint32_t version = get_u32(bin + 4), ns = get_u32(bin + 8), nv = get_u32(bin + 12);
    if (version != PROTO_GROOM_VERSION)
        return core_fail(err, CORE_EFORMAT, "groom data binary: version %u, expected %u", version, PROTO_GROOM_VERSION);
    if (ns < 1 || nv < 2)
        return core_fail(err, CORE_EFORMAT, "groom data binary: %u strands of %u vertices (at least 1 of 2 expected)", ns, nv);
    uint64_t want = PROTO_GROOM_HEADER + 16ull * ns;
    if (want != len)
        return core_fail(err, CORE_EFORMAT, "groom data binary: %u strands need %llu bytes, got %zu", ns,
                         (unsigned long long)want, len);
    const unsigned char *p = bin + PROTO_GROOM_HEADER;
    for (uint32_t s = 0; s < ns; s++, p += 4) {
        float f = get_f32(p);
        if (!isfinite(f) || f < 0.0f)
            return core_fail(err, CORE_EFORMAT, "groom data binary: strand %u's rest length is not a finite length", s);
    }
    for (size_t i = 0; i < 3u * (size_t)ns; i++, p += 4)
        if (!isfinite(get_f32(p)))
            return core_fail(err, CORE_EFORMAT, "groom data binary: strand %zu's root is not finite", i / 3);
    *nstrands = ns;
    *nverts = nv;
    return CORE_OK;
}
