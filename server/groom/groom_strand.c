/* groom: validation and resampling of one file strand (shared by the .tfx and .hair loaders). */
#include "groom.h"
#include "groom_internal.h"

#include <math.h>

core_status groom_take_strand(const unsigned char *data, size_t off, size_t stride, uint32_t n_in, float *tmp,
                              float *out, uint32_t n_out, uint32_t strand, const char *what, core_err *err)
{
    double len = 0.0;
    for (uint32_t v = 0; v < n_in; v++) {
        size_t at = off + (size_t)v * stride;
        for (int c = 0; c < 3; c++) {
            float f = groom_rd_f32(data, at + 4 * (size_t)c);
            if (!isfinite(f))
                return core_fail(err, CORE_EFORMAT, "%s: non-finite position at strand %u vertex %u (byte %zu)", what,
                                 strand, v, at + 4 * (size_t)c);
            tmp[3 * v + c] = f;
        }
        if (v > 0) {
            double dx = (double)tmp[3 * v] - tmp[3 * v - 3], dy = (double)tmp[3 * v + 1] - tmp[3 * v - 2],
                   dz = (double)tmp[3 * v + 2] - tmp[3 * v - 1];
            len += sqrt(dx * dx + dy * dy + dz * dz);
        }
    }
    if (!(len > 0.0) || !isfinite(len))
        return core_fail(err, CORE_EFORMAT, "%s: strand %u (byte %zu) has zero length (all %u points coincide)", what,
                         strand, off, n_in);
    core_err e;
    if (groom_resample_polyline(tmp, n_in, out, n_out, &e) != CORE_OK)
        return core_fail(err, CORE_EFORMAT, "%s: strand %u (byte %zu): %s", what, strand, off, e.msg);
    return CORE_OK;
}
