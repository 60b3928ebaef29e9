/* codec: the fixed frame header (write), the frame CRC and the byte buffer (the header is parsed
 * and checked by the decode core, codec_core.c). */
#include <stdlib.h>
#include <string.h>

#include "codec_core.h"
#include "codec_internal.h"

double codec_step_for_bound(float max_error_m)
{
    return 2.0 * (double)max_error_m * (1.0 - 1.0 / 32.0);
}

void codec_header_write(uint8_t *p, const codec_frame_info *info)
{
    uint64_t u64;
    uint32_t u32;
    memcpy(p, CODEC_MAGIC, 4);
    codec_put_u16(p + CODEC_OFF_VERSION, CODEC_VERSION);
    p[CODEC_OFF_CODEC] = (uint8_t)info->codec_id;
    p[CODEC_OFF_FLAGS] = info->keyframe ? CODEC_FLAG_KEY : 0u;
    codec_put_u64(p + CODEC_OFF_SEQ, info->seq);
    codec_put_u64(p + CODEC_OFF_REF, info->ref_seq);
    memcpy(&u64, &info->sim.sim_time, 8);
    codec_put_u64(p + CODEC_OFF_TIME, u64);
    codec_put_u64(p + CODEC_OFF_SIM_STEP, info->sim.sim_step);
    for (int i = 0; i < 3; i++) {
        memcpy(&u32, &info->sim.head_pos[i], 4);
        codec_put_u32(p + CODEC_OFF_HEAD_POS + 4 * i, u32);
    }
    for (int i = 0; i < 4; i++) {
        memcpy(&u32, &info->sim.head_rot[i], 4);
        codec_put_u32(p + CODEC_OFF_HEAD_ROT + 4 * i, u32);
    }
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
    return codec_core_crc32(codec_core_crc32(0, frame, CODEC_OFF_CRC), frame + CODEC_HEADER_SIZE, payload_len);
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
