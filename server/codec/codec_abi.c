/* codec_abi: the stable C ABI over the decoder (codec_abi.h): a handle holding a codec_decoder,
 * the header of the last frame read and the message of the last failure. */
#include "codec_abi.h"

#include <stdlib.h>
#include <string.h>

#include "codec.h"

struct codec_abi_decoder {
    codec_decoder dec;
    codec_frame_info info; /* the last frame's header; zeros before the first */
    core_err err;          /* the last failure's message; "" before the first */
};

uint32_t codec_abi_version(void)
{
    return CODEC_ABI_VERSION;
}

uint32_t codec_abi_format_version(void)
{
    return CODEC_VERSION;
}

const char *codec_abi_status_name(int status)
{
    return status >= CORE_OK && status <= CORE_ESTATE ? core_status_name((core_status)status) : "unknown";
}

codec_abi_decoder *codec_abi_decoder_new(void)
{
    codec_abi_decoder *d = calloc(1, sizeof *d);
    if (d) codec_decoder_init(&d->dec);
    return d;
}

void codec_abi_decoder_free(codec_abi_decoder *d)
{
    if (!d) return;
    codec_decoder_free(&d->dec);
    free(d);
}

int codec_abi_peek(codec_abi_decoder *d, const uint8_t *data, size_t len)
{
    if (!d) return CORE_EINVAL;
    codec_frame_info info;
    const core_status st = codec_peek_header(data, len, &info, &d->err);
    if (st == CORE_OK) d->info = info;
    return st;
}

int codec_abi_decode(codec_abi_decoder *d, const uint8_t *data, size_t len, float *out, size_t out_floats)
{
    if (!d) return CORE_EINVAL;
    codec_frame_info info;
    const core_status st = codec_decode(&d->dec, data, len, out, out_floats, &info, &d->err);
    if (st == CORE_OK) d->info = info;
    return st;
}

const char *codec_abi_message(const codec_abi_decoder *d)
{
    return d ? d->err.msg : "codec: NULL decoder";
}

/* The header held by d, or a zeroed one for NULL. */
static codec_frame_info held(const codec_abi_decoder *d)
{
    return d ? d->info : (codec_frame_info){ 0 };
}

uint64_t codec_abi_seq(const codec_abi_decoder *d) { return held(d).seq; }
uint64_t codec_abi_ref_seq(const codec_abi_decoder *d) { return held(d).ref_seq; }
int codec_abi_keyframe(const codec_abi_decoder *d) { return held(d).keyframe; }
double codec_abi_sim_time(const codec_abi_decoder *d) { return held(d).sim.sim_time; }
uint64_t codec_abi_sim_step(const codec_abi_decoder *d) { return held(d).sim.sim_step; }
double codec_abi_step(const codec_abi_decoder *d) { return held(d).step; }
float codec_abi_max_error_m(const codec_abi_decoder *d) { return held(d).max_error_m; }
uint32_t codec_abi_nstrands_total(const codec_abi_decoder *d) { return held(d).nstrands_total; }
uint32_t codec_abi_nstrands_sent(const codec_abi_decoder *d) { return held(d).nstrands_sent; }
uint32_t codec_abi_nverts(const codec_abi_decoder *d) { return held(d).nverts; }
uint32_t codec_abi_stride(const codec_abi_decoder *d) { return held(d).stride; }
uint32_t codec_abi_codec_id(const codec_abi_decoder *d) { return held(d).codec_id; }
uint32_t codec_abi_payload_len(const codec_abi_decoder *d) { return held(d).payload_len; }
uint64_t codec_abi_frame_len(const codec_abi_decoder *d) { return held(d).frame_len; }

void codec_abi_head_position(const codec_abi_decoder *d, float out[3])
{
    const codec_frame_info h = held(d);
    memcpy(out, h.sim.head_pos, sizeof h.sim.head_pos);
}

void codec_abi_head_orientation(const codec_abi_decoder *d, float out[4])
{
    const codec_frame_info h = held(d);
    memcpy(out, h.sim.head_rot, sizeof h.sim.head_rot);
}
