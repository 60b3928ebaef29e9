/* groom: arc-length uniform resampling of one polyline. */
#include "groom.h"

#include <math.h>

static double seg_len(const float *in, uint32_t i)
{
    double dx = (double)in[3 * (i + 1) + 0] - in[3 * i + 0];
    double dy = (double)in[3 * (i + 1) + 1] - in[3 * i + 1];
    double dz = (double)in[3 * (i + 1) + 2] - in[3 * i + 2];
    return sqrt(dx * dx + dy * dy + dz * dz);
}

core_status groom_resample_polyline(const float *in, uint32_t n_in, float *out, uint32_t n_out, core_err *err)
{
    if (n_in < 2 || n_out < 2)
        return core_fail(err, CORE_EINVAL, "resampling needs at least 2 points in and out (got %u -> %u)", n_in, n_out);
    double total = 0.0;
    for (uint32_t i = 0; i + 1 < n_in; i++) total += seg_len(in, i);
    if (!(total > 0.0) || !isfinite(total))
        return core_fail(err, CORE_EINVAL, "polyline of %u points has zero or non-finite length", n_in);

    for (int c = 0; c < 3; c++) {
        out[c] = in[c];
        out[3 * (n_out - 1) + c] = in[3 * (n_in - 1) + c];
    }
    /* Walk the input segments once; seg is the segment holding the target arc position. */
    uint32_t seg = 0;
    double start = 0.0, len = seg_len(in, 0);
    for (uint32_t j = 1; j + 1 < n_out; j++) {
        double target = total * (double)j / (double)(n_out - 1);
        while (seg + 2 < n_in && start + len < target) {
            start += len;
            seg++;
            len = seg_len(in, seg);
        }
        double t = len > 0.0 ? (target - start) / len : 0.0;
        if (t < 0.0) t = 0.0;
        if (t > 1.0) t = 1.0;
        for (int c = 0; c < 3; c++) {
            double a = in[3 * seg + c], b = in[3 * (seg + 1) + c];
            out[3 * j + c] = (float)(a + (b - a) * t);
        }
    }
    return CORE_OK;
}
