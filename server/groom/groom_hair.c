/* groom: Cem Yuksel .hair loader (128-byte "HAIR" header, optional arrays), pure bytes -> groom. */
#include "groom.h"
#include "groom_internal.h"

#include <stdlib.h>

#define HAIR_HEADER 128u
#define HAIR_SEGMENTS 1u
#define HAIR_POINTS 2u
#define HAIR_THICKNESS 4u
#define HAIR_TRANSPARENCY 8u
#define HAIR_COLORS 16u
#define HAIR_KNOWN 31u

/* Byte layout of the arrays after the header, from the counts and flags. */
typedef struct hair_layout {
    size_t seg_off, pts_off, end;
} hair_layout;

/* Adds an array of count * elem bytes at *end when flag is set; 0 on overflow. */
static int add_array(size_t *end, uint32_t flags, uint32_t flag, size_t count, size_t elem)
{
    size_t bytes;
    if (!(flags & flag)) return 1;
    if (!core_mul_size(count, elem, &bytes) || bytes > SIZE_MAX - *end) return 0;
    *end += bytes;
    return 1;
}

static core_status layout(uint32_t flags, uint32_t nh, uint32_t np, size_t size, hair_layout *l, core_err *err)
{
    l->end = HAIR_HEADER;
    l->seg_off = l->end;
    int ok = add_array(&l->end, flags, HAIR_SEGMENTS, nh, 2);
    l->pts_off = l->end;
    ok = ok && add_array(&l->end, flags, HAIR_POINTS, np, 12) && add_array(&l->end, flags, HAIR_THICKNESS, np, 4) &&
         add_array(&l->end, flags, HAIR_TRANSPARENCY, np, 4) && add_array(&l->end, flags, HAIR_COLORS, np, 12);
    if (!ok) return core_fail(err, CORE_EFORMAT, ".hair: array sizes overflow (%u hairs, %u points)", nh, np);
    if (size < l->end)
        return core_fail(err, CORE_EFORMAT, ".hair: truncated: header (%u hairs, %u points, flags 0x%x) implies %zu bytes, file has %zu",
                         nh, np, flags, l->end, size);
    if (size > l->end)
        return core_fail(err, CORE_EFORMAT, ".hair: size disagrees with the header: %zu trailing bytes after byte %zu",
                         size - l->end, l->end);
    return CORE_OK;
}

/* Points per strand s: from the segments array or the default. */
static uint32_t strand_points(const unsigned char *b, const hair_layout *l, uint32_t flags, uint32_t dseg, uint32_t s)
{
    if (!(flags & HAIR_SEGMENTS)) return dseg + 1;
    size_t at = l->seg_off + 2 * (size_t)s;
    return (uint32_t)(b[at] | b[at + 1] << 8) + 1;
}

/* Checks per-strand counts against the point count; finds the largest and whether all agree. */
static core_status check_counts(const unsigned char *b, const hair_layout *l, uint32_t flags, uint32_t nh, uint32_t np,
                                uint32_t dseg, uint32_t *max_pts, int *uniform, core_err *err)
{
    if (!(flags & HAIR_SEGMENTS) && (dseg == 0 || dseg >= 65536u))
        return core_fail(err, CORE_EFORMAT, ".hair: default segment count %u (byte 16) out of range [1, 65535]", dseg);
    uint64_t total = 0;
    *max_pts = 0;
    *uniform = 1;
    for (uint32_t s = 0; s < nh; s++) {
        uint32_t n = strand_points(b, l, flags, dseg, s);
        if (n < 2)
            return core_fail(err, CORE_EFORMAT, ".hair: strand %u has %u point (< 2 points; segments at byte %zu)", s, n,
                             l->seg_off + 2 * (size_t)s);
        if (s > 0 && n != *max_pts) *uniform = 0;
        if (n > *max_pts) *max_pts = n;
        total += n;
    }
    if (total != np)
        return core_fail(err, CORE_EFORMAT, ".hair: segment counts give %llu points but the header (byte 8) says %u",
                         (unsigned long long)total, np);
    return CORE_OK;
}

core_status groom_load_hair(const void *data, size_t size, uint32_t nverts, core_groom *out, core_err *err)
{
    const unsigned char *b = data;
    memset(out, 0, sizeof *out);
    if (!b || size < HAIR_HEADER)
        return core_fail(err, CORE_EFORMAT, ".hair: truncated: %zu bytes, the header alone needs %u", b ? size : 0,
                         HAIR_HEADER);
    if (memcmp(b, "HAIR", 4) != 0)
        return core_fail(err, CORE_EFORMAT, ".hair: wrong magic at byte 0 (expected \"HAIR\")");
    uint32_t nh = groom_rd_u32(b, 4), np = groom_rd_u32(b, 8), flags = groom_rd_u32(b, 12), dseg = groom_rd_u32(b, 16);
    if (nh == 0 || nh > GROOM_MAX_STRANDS)
        return core_fail(err, CORE_EFORMAT, ".hair: hair count %u (byte 4) out of range [1, %u] strands", nh,
                         GROOM_MAX_STRANDS);
    if (np < 2 || np > GROOM_MAX_TOTAL)
        return core_fail(err, CORE_EFORMAT, ".hair: point count %u (byte 8) out of range [2, %u]", np, GROOM_MAX_TOTAL);
    if (flags & ~HAIR_KNOWN)
        return core_fail(err, CORE_EFORMAT, ".hair: unknown array flags 0x%x (byte 12)", flags & ~HAIR_KNOWN);
    if (!(flags & HAIR_POINTS))
        return core_fail(err, CORE_EFORMAT, ".hair: no points array (flags 0x%x at byte 12 lack 0x2)", flags);
    hair_layout l;
    core_status st = layout(flags, nh, np, size, &l, err);
    if (st != CORE_OK) return st;
    uint32_t max_pts = 0;
    int uniform = 0;
    st = check_counts(b, &l, flags, nh, np, dseg, &max_pts, &uniform, err);
    if (st != CORE_OK) return st;

    uint32_t nv = nverts ? nverts : (uniform && max_pts <= GROOM_MAX_VERTS ? max_pts : GROOM_DEFAULT_VERTS);
    if (nv < 2 || nv > GROOM_MAX_VERTS)
        return core_fail(err, CORE_EINVAL, "target vertices per strand %u out of range [2, %u]", nv, GROOM_MAX_VERTS);
    if ((uint64_t)nh * nv > GROOM_MAX_TOTAL)
        return core_fail(err, CORE_EINVAL, "%u strands x %u vertices exceed the %u vertex limit", nh, nv,
                         GROOM_MAX_TOTAL);
    float *tmp = malloc((size_t)max_pts * 3 * sizeof(float));
    if (!tmp) return core_fail(err, CORE_ENOMEM, ".hair: out of memory for a strand of %u points", max_pts);
    st = core_groom_alloc(out, nh, nv, err);
    size_t off = l.pts_off;
    for (uint32_t s = 0; st == CORE_OK && s < nh; s++) {
        uint32_t n = strand_points(b, &l, flags, dseg, s);
        st = groom_take_strand(b, off, 12, n, tmp, out->pos + (size_t)s * nv * 3, nv, s, ".hair", err);
        off += (size_t)n * 12;
    }
    free(tmp);
    if (st != CORE_OK) core_groom_free(out);
    return st;
}
