/* proto: the hair mesh topology binary served at /hairmesh.bin (faces, guides, rest vertices;
 * write, check). */
#include <math.h>
#include <string.h>

#include "proto.h"
#include "proto_bin.h"

size_t proto_hairmesh_bin_size(const core_hairmesh *m)
{
    return PROTO_HAIRMESH_HEADER + 16u * (size_t)m->nfaces + 12u * (size_t)m->nguides +
           12u * (size_t)m->ncols * m->nlayers;
}

void proto_hairmesh_bin_write(const core_hairmesh *m, unsigned char *out)
{
    memcpy(out, PROTO_HAIRMESH_MAGIC, 4);
    proto_bin_put_u32(out + 4, PROTO_HAIRMESH_VERSION);
    proto_bin_put_u32(out + 8, m->ncols);
    proto_bin_put_u32(out + 12, m->nlayers);
    proto_bin_put_u32(out + 16, m->nfaces);
    proto_bin_put_u32(out + 20, m->nguides);
    unsigned char *p = out + PROTO_HAIRMESH_HEADER;
    for (size_t i = 0; i < 4u * (size_t)m->nfaces; i++, p += 4) proto_bin_put_u32(p, m->faces[i]);
    for (size_t i = 0; i < m->nguides; i++, p += 4) proto_bin_put_u32(p, m->guide_face[i]);
    for (size_t i = 0; i < 2u * (size_t)m->nguides; i++, p += 4) proto_bin_put_f32(p, m->guide_uv[i]);
    for (size_t i = 0; i < 3u * (size_t)m->ncols * m->nlayers; i++, p += 4) proto_bin_put_f32(p, m->pos[i]);
}

/* Face f's corners at p (4 uint32): in range, distinct, a triangle's 4th CORE_HAIRMESH_NONE. */
static core_status check_face(const unsigned char *p, uint32_t f, uint32_t ncols, core_err *err)
{
    uint32_t c[4];
    for (int k = 0; k < 4; k++) c[k] = proto_bin_get_u32(p + 4 * k);
    int n = c[3] == CORE_HAIRMESH_NONE ? 3 : 4;
    for (int k = 0; k < n; k++) {
        if (c[k] >= ncols)
            return core_fail(err, CORE_EFORMAT, "hair mesh binary: face %u corner %d is column %u, past the %u columns", f,
                             k, c[k], ncols);
        for (int j = 0; j < k; j++)
            if (c[j] == c[k])
                return core_fail(err, CORE_EFORMAT, "hair mesh binary: face %u uses column %u twice", f, c[k]);
    }
    return CORE_OK;
}

core_status proto_hairmesh_bin_read(const unsigned char *bin, size_t len, proto_hairmesh_counts *out, core_err *err)
{
    memset(out, 0, sizeof *out);
    uint32_t ncols, nlayers;
    core_status st = proto_bin_header(bin, len, PROTO_HAIRMESH_MAGIC, PROTO_HAIRMESH_VERSION, "hair mesh binary", &ncols,
                                      &nlayers, err);
    if (st != CORE_OK) return st;
    if (len < PROTO_HAIRMESH_HEADER)
        return core_fail(err, CORE_EFORMAT, "hair mesh binary: %zu bytes, shorter than its %u-byte header", len,
                         PROTO_HAIRMESH_HEADER);
    uint32_t nfaces = proto_bin_get_u32(bin + 16), nguides = proto_bin_get_u32(bin + 20);
    if (ncols < 3 || nlayers < 2 || nfaces < 1)
        return core_fail(err, CORE_EFORMAT,
                         "hair mesh binary: %u columns, %u layers, %u faces (at least 3, 2 and 1 expected)", ncols, nlayers,
                         nfaces);
    uint64_t want = PROTO_HAIRMESH_HEADER + 16ull * nfaces + 12ull * nguides + 12ull * ncols * nlayers;
    if (want != len)
        return core_fail(err, CORE_EFORMAT, "hair mesh binary: %u faces, %u guides and %u x %u vertices need %llu bytes, got %zu",
                         nfaces, nguides, ncols, nlayers, (unsigned long long)want, len);
    const unsigned char *p = bin + PROTO_HAIRMESH_HEADER;
    for (uint32_t f = 0; f < nfaces; f++, p += 16)
        if ((st = check_face(p, f, ncols, err)) != CORE_OK) return st;
    for (uint32_t g = 0; g < nguides; g++, p += 4)
        if (proto_bin_get_u32(p) >= nfaces)
            return core_fail(err, CORE_EFORMAT, "hair mesh binary: guide %u is in face %u, past the %u faces", g,
                             proto_bin_get_u32(p), nfaces);
    for (size_t i = 0; i < 2u * (size_t)nguides; i++, p += 4)
        if (!isfinite(proto_bin_get_f32(p)))
            return core_fail(err, CORE_EFORMAT, "hair mesh binary: guide %zu's coordinates are not finite", i / 2);
    for (size_t i = 0; i < 3u * (size_t)ncols * nlayers; i++, p += 4)
        if (!isfinite(proto_bin_get_f32(p)))
            return core_fail(err, CORE_EFORMAT, "hair mesh binary: column %zu layer %zu is not finite", i / 3 / nlayers,
                             i / 3 % nlayers);
    *out = (proto_hairmesh_counts){ ncols, nlayers, nfaces, nguides };
    return CORE_OK;
}
