/* groom: TressFX .tfx loader (160-byte header, float4 positions), pure bytes -> groom. */
#include "groom.h"
#include "groom_internal.h"

#include <math.h>
#include <stdlib.h>

#define TFX_HEADER 160u
#define TFX_OFF_POS 12u  /* byte offset of offsetVertexPosition in the header */
#define TFX_OFF_FIRST_OPTIONAL 16u

static const char *const optional_names[] = { "offsetStrandUV", "offsetVertexUV", "offsetStrandThickness",
                                               "offsetVertexColor" };

/* Checks the optional array offsets: outside the header, inside the file, not inside the
 * position array; the strand UVs (float2 per strand) must fit entirely. */
static core_status check_optional(const unsigned char *b, size_t size, uint32_t nstrands, size_t pos_off,
                                  size_t pos_end, core_err *err)
{
    for (uint32_t i = 0; i < 4; i++) {
        size_t at = TFX_OFF_FIRST_OPTIONAL + 4 * (size_t)i;
        size_t off = groom_rd_u32(b, at);
        if (off == 0) continue;
        if (off < TFX_HEADER)
            return core_fail(err, CORE_EFORMAT, ".tfx: %s = %zu (byte %zu) overlaps the %u-byte header",
                             optional_names[i], off, at, TFX_HEADER);
        if (off >= size)
            return core_fail(err, CORE_EFORMAT, ".tfx: %s = %zu (byte %zu) is out of range (file is %zu bytes)",
                             optional_names[i], off, at, size);
        if (off >= pos_off && off < pos_end)
            return core_fail(err, CORE_EFORMAT, ".tfx: %s = %zu (byte %zu) overlaps the positions [%zu, %zu)",
                             optional_names[i], off, at, pos_off, pos_end);
        if (i == 0) {
            size_t uv_end = off + (size_t)nstrands * 8;
            if (uv_end > size)
                return core_fail(err, CORE_EFORMAT,
                                 ".tfx: strand UVs at byte %zu need %zu bytes, out of range (file is %zu bytes)", off,
                                 (size_t)nstrands * 8, size);
            if (off < pos_off && uv_end > pos_off)
                return core_fail(err, CORE_EFORMAT, ".tfx: strand UVs [%zu, %zu) overlap the positions at byte %zu", off,
                                 uv_end, pos_off);
        }
    }
    return CORE_OK;
}

core_status groom_load_tfx(const void *data, size_t size, uint32_t nverts, core_groom *out, core_err *err)
{
    const unsigned char *b = data;
    memset(out, 0, sizeof *out);
    if (!b || size < TFX_HEADER)
        return core_fail(err, CORE_EFORMAT, ".tfx: truncated: %zu bytes, the header alone needs %u", b ? size : 0,
                         TFX_HEADER);
    float version = groom_rd_f32(b, 0);
    if (!isfinite(version) || !(version > 0.0f) || version > 100.0f)
        return core_fail(err, CORE_EFORMAT, ".tfx: bad version %g at byte 0 (not a TressFX file?)", (double)version);
    uint32_t ns = groom_rd_u32(b, 4), nv_in = groom_rd_u32(b, 8);
    if (ns == 0 || ns > GROOM_MAX_STRANDS)
        return core_fail(err, CORE_EFORMAT, ".tfx: numHairStrands %u (byte 4) out of range [1, %u]", ns,
                         GROOM_MAX_STRANDS);
    if (nv_in < 2 || nv_in > GROOM_MAX_VERTS)
        return core_fail(err, CORE_EFORMAT, ".tfx: numVerticesPerStrand %u (byte 8) out of range [2, %u]", nv_in,
                         GROOM_MAX_VERTS);
    if ((uint64_t)ns * nv_in > GROOM_MAX_TOTAL)
        return core_fail(err, CORE_EFORMAT, ".tfx: %u strands x %u vertices exceed the %u vertex limit", ns, nv_in,
                         GROOM_MAX_TOTAL);
    uint32_t nv = nverts ? nverts : nv_in;
    if (nv < 2 || nv > GROOM_MAX_VERTS)
        return core_fail(err, CORE_EINVAL, "target vertices per strand %u out of range [2, %u]", nv, GROOM_MAX_VERTS);
    if ((uint64_t)ns * nv > GROOM_MAX_TOTAL)
        return core_fail(err, CORE_EINVAL, "%u strands x %u vertices exceed the %u vertex limit", ns, nv,
                         GROOM_MAX_TOTAL);

    size_t pos_off = groom_rd_u32(b, TFX_OFF_POS), pos_bytes;
    if (pos_off == 0)
        return core_fail(err, CORE_EFORMAT, ".tfx: no vertex positions (offsetVertexPosition at byte %u is 0)",
                         TFX_OFF_POS);
    if (pos_off < TFX_HEADER)
        return core_fail(err, CORE_EFORMAT, ".tfx: offsetVertexPosition = %zu (byte %u) overlaps the %u-byte header",
                         pos_off, TFX_OFF_POS, TFX_HEADER);
    if (!core_mul_size((size_t)ns * nv_in, 16, &pos_bytes) || pos_off > size || pos_bytes > size - pos_off)
        return core_fail(err, CORE_EFORMAT,
                         ".tfx: truncated: positions at byte %zu need %u x %u x 16 bytes, out of range (file is %zu bytes)",
                         pos_off, ns, nv_in, size);
    core_status st = check_optional(b, size, ns, pos_off, pos_off + pos_bytes, err);
    if (st != CORE_OK) return st;

    float *tmp = malloc((size_t)nv_in * 3 * sizeof(float));
    if (!tmp) return core_fail(err, CORE_ENOMEM, ".tfx: out of memory for a strand of %u vertices", nv_in);
    st = core_groom_alloc(out, ns, nv, err);
    for (uint32_t s = 0; st == CORE_OK && s < ns; s++) {
        size_t off = pos_off + (size_t)s * nv_in * 16;
        st = groom_take_strand(b, off, 16, nv_in, tmp, out->pos + (size_t)s * nv * 3, nv, s, ".tfx", err);
    }
    free(tmp);
    if (st != CORE_OK) core_groom_free(out);
    return st;
}
