/* fuzz_codec: libFuzzer target for the strand frame decoder (codec_peek_header, codec_decode).
 * An input is a sequence of frames back to back (a keyframe then deltas, as the seeds are), all
 * decoded by one decoder so the delta paths see a held keyframe. Each frame's CRC (header bytes
 * 64..67, proto/CODEC.md) is recomputed before decoding, so mutations reach the payload
 * decoder instead of stopping at the checksum. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "codec/codec.h"

#define FUZZ_MAX_FRAMES 4
#define FUZZ_MAX_FLOATS (3u << 16) /* larger frames are skipped (memory, time) */

/* Writes the CRC-32 of header bytes 0..63 and the payload into bytes 64..67 (little-endian) of
 * frame[0, len), len >= CODEC_HEADER_SIZE. */
static void fix_crc(uint8_t *frame, size_t len)
{
    uLong c = crc32(0L, frame, 64);
    c = crc32(c, frame + CODEC_HEADER_SIZE, (uInt)(len - CODEC_HEADER_SIZE));
    for (int i = 0; i < 4; i++) frame[64 + i] = (uint8_t)(c >> (8 * i));
}

/* Bytes of the frame at the start of data[0, size): 68 + its header's payload_len (bytes
 * 60..63), at most size; size when the header is not all there. */
static size_t frame_bytes(const uint8_t *data, size_t size)
{
    if (size < CODEC_HEADER_SIZE) return size;
    uint32_t payload = (uint32_t)data[60] | (uint32_t)data[61] << 8 | (uint32_t)data[62] << 16 | (uint32_t)data[63] << 24;
    size_t n = CODEC_HEADER_SIZE + (size_t)payload;
    return n < size ? n : size;
}

/* Decodes the frame data[0, len) with dec, its CRC fixed first, into an output buffer of
 * exactly the size the header needs (so ASan sees any write past it). A frame whose header
 * does not parse, or over FUZZ_MAX_FLOATS, goes to codec_decode as it is with a one-float
 * buffer: it must be refused. */
static void decode_one(codec_decoder *dec, const uint8_t *data, size_t len)
{
    codec_frame_info info;
    core_err err;
    float one;
    size_t floats = 0;
    if (codec_peek_header(data, len, &info, &err) == CORE_OK) floats = 3 * (size_t)info.nstrands_sent * info.nverts;
    if (floats == 0 || floats > FUZZ_MAX_FLOATS) {
        if (codec_decode(dec, data, len, &one, 1, NULL, &err) == CORE_OK) __builtin_trap();
        return;
    }
    float *xyz = malloc(floats * sizeof *xyz);
    uint8_t *frame = malloc(len);
    if (xyz && frame) {
        memcpy(frame, data, len);
        fix_crc(frame, len);
        codec_frame_info got;
        if (codec_decode(dec, frame, len, xyz, floats, &got, &err) == CORE_OK &&
            (got.frame_len != len || got.seq != info.seq))
            __builtin_trap();
    }
    free(frame);
    free(xyz);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    codec_decoder dec;
    codec_decoder_init(&dec);
    size_t at = 0;
    for (int i = 0; i < FUZZ_MAX_FRAMES && at < size; i++) {
        size_t len = frame_bytes(data + at, size - at);
        decode_one(&dec, data + at, len);
        at += len;
    }
    codec_decoder_free(&dec);
    return 0;
}
