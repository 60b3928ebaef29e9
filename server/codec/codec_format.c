/* codec: the fixed frame header (write, parse, validate), the CRC and the byte buffer. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "codec_internal.h"

double codec_step_for_bound(float max_error_m)
{
    return 2.0 * (double)max_error_m * (1.0 - 1.0 / 32.0);
}

static double get_f64(const uint8_t *p)
{
    uint64_t u = codec_get_u64(p);
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}

static float get_f32(const uint8_t *p)
{
    uint32_t u = codec_get_u32(p);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

void codec_header_write(uint8_t *p, const codec_frame_info *info)
{
    uint64_t u64;
    uint32_t u32;
    memcpy(p, CODEC_MAGIC, 4);
    codec_put_u16(p + CODEC_OFF_VERSION, CODEC_VERSION);
    p[CODEC_OFF_CODEC] = CODEC_ID_STRAND;
    p[CODEC_OFF_FLAGS] = info->keyframe ? CODEC_FLAG_KEY : 0u;
    codec_put_u64(p + CODEC_OFF_SEQ, info->seq);
    codec_put_u64(p + CODEC_OFF_REF, info->ref_seq);
    memcpy(&u64, &info->sim_time, 8);
    codec_put_u64(p + CODEC_OFF_TIME, u64);
    memcpy(&u64, &info->step, 8);
    codec_put_u64(p + CODEC_OFF_STEP, u64);
    memcpy(&u32, &info->max_error_m, 4);
    codec_put_u32(p + CODEC_OFF_BOUND, u32);
    codec_put_u32(p + CODEC_OFF_TOTAL, info->nstrands_total);
    codec_put_u32(p + CODEC_OFF_SENT, info->nstrands_sent);
    codec_put_u32(p + CODEC_OFF_NVERTS, info->nverts);
    codec_put_u32(p + CODEC_OFF_STRIDE, info->stride);
    codec_put_u32(p + CODEC_OFF_PAYLOAD, info->payload_len);
    codec_put_u32(p + CODEC_OFF_CRC, 0);
}

uint32_t codec_frame_crc(const uint8_t *frame, size_t payload_len)
{
    return codec_crc32(codec_crc32(0, frame, CODEC_OFF_CRC), frame + CODEC_HEADER_SIZE, payload_len);
}

core_status codec_peek_header(const uint8_t *data, size_t len, codec_frame_info *info, core_err *err)
{
    if (!data || !info) return core_fail(err, CORE_EINVAL, "codec: NULL frame or info");
    if (len < CODEC_HEADER_SIZE)
        return core_fail(err, CORE_EFORMAT, "codec: truncated header (%zu bytes, need %u)", len,
                         CODEC_HEADER_SIZE);
    if (memcmp(data, CODEC_MAGIC, 4) != 0)
        return core_fail(err, CORE_EFORMAT, "codec: bad magic (not a strand frame)");
    uint32_t version = codec_get_u16(data + CODEC_OFF_VERSION);
    if (version != CODEC_VERSION)
        return core_fail(err, CORE_EFORMAT, "codec: unsupported format version %u (this decoder reads %u)",
                         version, CODEC_VERSION);
    if (data[CODEC_OFF_CODEC] != CODEC_ID_STRAND)
        return core_fail(err, CORE_EFORMAT, "codec: unknown codec id %u", data[CODEC_OFF_CODEC]);
    uint32_t flags = data[CODEC_OFF_FLAGS];
    if (flags & ~CODEC_FLAG_KEY) return core_fail(err, CORE_EFORMAT, "codec: unknown flags 0x%02x", flags);
    codec_frame_info h;
    memset(&h, 0, sizeof h);
    h.keyframe = (flags & CODEC_FLAG_KEY) != 0;
    h.seq = codec_get_u64(data + CODEC_OFF_SEQ);
    h.ref_seq = codec_get_u64(data + CODEC_OFF_REF);
    h.sim_time = get_f64(data + CODEC_OFF_TIME);
    h.step = get_f64(data + CODEC_OFF_STEP);
    h.max_error_m = get_f32(data + CODEC_OFF_BOUND);
    h.nstrands_total = codec_get_u32(data + CODEC_OFF_TOTAL);
    h.nstrands_sent = codec_get_u32(data + CODEC_OFF_SENT);
    h.nverts = codec_get_u32(data + CODEC_OFF_NVERTS);
    h.stride = codec_get_u32(data + CODEC_OFF_STRIDE);
    h.payload_len = codec_get_u32(data + CODEC_OFF_PAYLOAD);
    h.frame_len = (size_t)CODEC_HEADER_SIZE + h.payload_len;
    if (h.keyframe ? h.ref_seq != h.seq : h.ref_seq >= h.seq)
        return core_fail(err, CORE_EFORMAT, "codec: reference sequence %llu invalid for %s %llu",
                         (unsigned long long)h.ref_seq, h.keyframe ? "keyframe" : "delta frame",
                         (unsigned long long)h.seq);
    if (!isfinite(h.sim_time)) return core_fail(err, CORE_EFORMAT, "codec: sim time is not finite");
    if (!(h.max_error_m >= 1e-5f && h.max_error_m <= 0.1f))
        return core_fail(err, CORE_EFORMAT, "codec: error bound %g m outside [1e-5, 0.1]", (double)h.max_error_m);
    if (!(h.step > 0.0 && h.step <= 2.0 * (double)h.max_error_m))
        return core_fail(err, CORE_EFORMAT, "codec: quantization step %g m does not meet bound %g m", h.step,
                         (double)h.max_error_m);
    if (h.nverts < 2 || h.nverts > CODEC_MAX_NVERTS)
        return core_fail(err, CORE_EFORMAT, "codec: %u vertices per strand outside [2, %u]", h.nverts,
                         CODEC_MAX_NVERTS);
    if (h.stride < 1 || h.nstrands_total < 1)
        return core_fail(err, CORE_EFORMAT, "codec: stride %u / strand count %u must be positive", h.stride,
                         h.nstrands_total);
    uint64_t sent = ((uint64_t)h.nstrands_total + h.stride - 1u) / h.stride;
    if (h.nstrands_sent != sent)
        return core_fail(err, CORE_EFORMAT, "codec: %u strands sent but %u strands at stride %u give %llu",
                         h.nstrands_sent, h.nstrands_total, h.stride, (unsigned long long)sent);
    if ((uint64_t)h.nstrands_sent * h.nverts > CODEC_MAX_VERTICES)
        return core_fail(err, CORE_EFORMAT, "codec: %u x %u vertices exceed the limit %u", h.nstrands_sent,
                         h.nverts, CODEC_MAX_VERTICES);
    if (len != h.frame_len)
        return core_fail(err, CORE_EFORMAT, "codec: frame is %zu bytes but its header says %zu (%s)", len,
                         h.frame_len, len < h.frame_len ? "truncated" : "trailing bytes");
    *info = h;
    return CORE_OK;
}

core_status codec_buf_reserve(codec_buf *buf, size_t cap, core_err *err)
{
    if (buf->cap >= cap) return CORE_OK;
    size_t ncap = buf->cap ? buf->cap : 4096;
    while (ncap < cap) {
        if (ncap > SIZE_MAX / 2) return core_fail(err, CORE_ENOMEM, "codec: buffer size overflow");
        ncap *= 2;
    }
    uint8_t *p = realloc(buf->data, ncap);
    if (!p) return core_fail(err, CORE_ENOMEM, "codec: out of memory for a %zu-byte frame", ncap);
    buf->data = p;
    buf->cap = ncap;
    return CORE_OK;
}

void codec_buf_free(codec_buf *buf)
{
    if (!buf) return;
    free(buf->data);
    memset(buf, 0, sizeof *buf);
}
