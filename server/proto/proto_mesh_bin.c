/* proto: the collision mesh binary served at /collider.bin (write, check). */
#include <math.h>
#include <string.h>

#include "proto.h"
#include "proto_bin.h"

size_t proto_mesh_bin_size(const core_mesh *m)
{
    return PROTO_MESH_HEADER + 12u * (size_t)m->nverts + 12u * (size_t)m->ntris;
}

void proto_mesh_bin_write(const core_mesh *m, unsigned char *out)
{
    memcpy(out, PROTO_MESH_MAGIC, 4);
    proto_bin_put_u32(out + 4, PROTO_MESH_VERSION);
    proto_bin_put_u32(out + 8, m->nverts);
    proto_bin_put_u32(out + 12, m->ntris);
    unsigned char *p = out + PROTO_MESH_HEADER;
    for (size_t i = 0; i < 3u * (size_t)m->nverts; i++, p += 4) {
        uint32_t bits;
        memcpy(&bits, &m->pos[i], 4);
        proto_bin_put_u32(p, bits);
    }
    for (size_t i = 0; i < 3u * (size_t)m->ntris; i++, p += 4) proto_bin_put_u32(p, m->tri[i]);
}

core_status proto_mesh_bin_read(const unsigned char *bin, size_t len, uint32_t *nverts, uint32_t *ntris, core_err *err)
{
    *nverts = *ntris = 0;
    uint32_t nv, nt;
    core_status st = proto_bin_header(bin, len, PROTO_MESH_MAGIC, PROTO_MESH_VERSION, "collider mesh binary", &nv, &nt, err);
    if (st != CORE_OK) return st;
    uint64_t want = PROTO_MESH_HEADER + 12ull * nv + 12ull * nt;
    if (want != len)
        return core_fail(err, CORE_EFORMAT, "collider mesh binary: %u vertices and %u triangles need %llu bytes, got %zu", nv, nt,
                         (unsigned long long)want, len);
    const unsigned char *p = bin + PROTO_MESH_HEADER;
    for (size_t i = 0; i < 3u * (size_t)nv; i++, p += 4) {
        uint32_t bits = proto_bin_get_u32(p);
        float f;
        memcpy(&f, &bits, 4);
        if (!isfinite(f)) return core_fail(err, CORE_EFORMAT, "collider mesh binary: vertex %zu is not finite", i / 3);
    }
    for (size_t i = 0; i < 3u * (size_t)nt; i++, p += 4)
        if (proto_bin_get_u32(p) >= nv)
            return core_fail(err, CORE_EFORMAT, "collider mesh binary: triangle %zu uses vertex %u of %u", i / 3, proto_bin_get_u32(p), nv);
    *nverts = nv;
    *ntris = nt;
    return CORE_OK;
}
