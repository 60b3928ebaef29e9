/* proto: the collision mesh binary served at /collider.bin (write, check). */
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

size_t proto_mesh_bin_size(const core_mesh *m)
{
    return PROTO_MESH_HEADER + 12u * (size_t)m->nverts + 12u * (size_t)m->ntris;
}

void proto_mesh_bin_write(const core_mesh *m, unsigned char *out)
{
    memcpy(out, PROTO_MESH_MAGIC, 4);
    put_u32(out + 4, PROTO_MESH_VERSION);
    put_u32(out + 8, m->nverts);
    put_u32(out + 12, m->ntris);
    unsigned char *p = out + PROTO_MESH_HEADER;
    for (size_t i = 0; i < 3u * (size_t)m->nverts; i++, p += 4) {
        uint32_t bits;
        memcpy(&bits, &m->pos[i], 4);
        put_u32(p, bits);
    }
    for (size_t i = 0; i < 3u * (size_t)m->ntris; i++, p += 4) put_u32(p, m->tri[i]);
}

core_status proto_mesh_bin_read(const unsigned char *bin, size_t len, uint32_t *nverts, uint32_t *ntris, core_err *err)
{
    *nverts = *ntris = 0;
    if (len < PROTO_MESH_HEADER || memcmp(bin, PROTO_MESH_MAGIC, 4) != 0)
        return core_fail(err, CORE_EFORMAT, "collider mesh binary: %zu bytes without the \"%s\" header", len, PROTO_MESH_MAGIC);
    uint32_t version = get_u32(bin + 4), nv = get_u32(bin + 8), nt = get_u32(bin + 12);
    if (version != PROTO_MESH_VERSION)
        return core_fail(err, CORE_EFORMAT, "collider mesh binary: version %u, expected %u", version, PROTO_MESH_VERSION);
    uint64_t want = PROTO_MESH_HEADER + 12ull * nv + 12ull * nt;
    if (want != len)
        return core_fail(err, CORE_EFORMAT, "collider mesh binary: %u vertices and %u triangles need %llu bytes, got %zu", nv, nt,
                         (unsigned long long)want, len);
    const unsigned char *p = bin + PROTO_MESH_HEADER;
    for (size_t i = 0; i < 3u * (size_t)nv; i++, p += 4) {
        uint32_t bits = get_u32(p);
        float f;
        memcpy(&f, &bits, 4);
        if (!isfinite(f)) return core_fail(err, CORE_EFORMAT, "collider mesh binary: vertex %zu is not finite", i / 3);
    }
    for (size_t i = 0; i < 3u * (size_t)nt; i++, p += 4)
        if (get_u32(p) >= nv)
            return core_fail(err, CORE_EFORMAT, "collider mesh binary: triangle %zu uses vertex %u of %u", i / 3, get_u32(p), nv);
    *nverts = nv;
    *ntris = nt;
    return CORE_OK;
}
