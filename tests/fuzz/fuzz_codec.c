/* fuzz_codec: libFuzzer target for the strand frame decoder (codec_peek_header, codec_decode).
 * An input is a sequence of frames back to back (a keyframe then deltas, as the seeds are), all
 * decoded by one decoder so the delta paths see a held keyframe. A frame runs to the next
 * "SCF1" magic (or the end); its header's payload_len and CRC (bytes 60..63 and 100..103,
 * proto/CODEC.md)
 * are rewritten to match before decoding, so inserted or erased bytes and other mutations reach
 * the payload decoder instead of stopping at the length or checksum check. The frame as it
 * came also goes through codec_peek_header, which checks both. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "codec/codec.h"

#define FUZZ_MAX_FRAMES 4
#define FUZZ_MAX_FLOATS (3u << 16) /* larger frames are skipped (memory, time) */

/* Writes len - CODEC_HEADER_SIZE as payload_len (bytes 60..63) and the CRC-32 of the header bytes
 * before the CRC field and the payload into the CRC field (the header's last 4 bytes,
 * little-endian) of frame[0, len), len >= CODEC_HEADER_SIZE. */
static void fix_length_crc(uint8_t *frame, size_t len)
{
    const uint32_t payload = (uint32_t)(len - CODEC_HEADER_SIZE);
    for (int i = 0; i < 4; i++) frame[60 + i] = (uint8_t)(payload >> (8 * i));
    uLong c = crc32(0L, frame, CODEC_HEADER_SIZE - 4u);
    c = crc32(c, frame + CODEC_HEADER_SIZE, (uInt)(len - CODEC_HEADER_SIZE));
    for (int i = 0; i < 4; i++) frame[CODEC_HEADER_SIZE - 4u + (unsigned)i] = (uint8_t)(c >> (8 * i));
}

/* Bytes of the frame at the start of data[0, size): up to the next CODEC_MAGIC after the
 * header's first 4 bytes, or size. */
static size_t frame_bytes(const uint8_t *data, size_t size)
{
    for (size_t i = 4; i + 4 <= size; i++)
        if (memcmp(data + i, CODEC_MAGIC, 4) == 0) return i;
    return size;
}

/* Decodes the frame data[0, len) with dec, payload_len and CRC fixed first, into an output
 * buffer of exactly the size the header needs (so ASan sees any write past it). A frame whose
 * header does not parse, or over FUZZ_MAX_FLOATS, goes to codec_decode with a one-float
 * buffer: it must be refused. */
static void decode_one(codec_decoder *dec, const uint8_t *data, size_t len)
{
    codec_frame_info info;
    core_err err;
    float one;
    (void)codec_peek_header(data, len, &info, &err);
    uint8_t *frame = malloc(len ? len : 1);
    if (!frame) return;
    memcpy(frame, data, len);
    if (len >= CODEC_HEADER_SIZE) fix_length_crc(frame, len);
    size_t floats = 0;
    if (codec_peek_header(frame, len, &info, &err) == CORE_OK) floats = 3 * (size_t)info.nstrands_sent * info.nverts;
    if (floats == 0 || floats > FUZZ_MAX_FLOATS) {
        if (codec_decode(dec, frame, len, &one, 1, NULL, &err) == CORE_OK) __builtin_trap();
        free(frame);
        return;
    }
    float *xyz = malloc(floats * sizeof *xyz);
    codec_frame_info got;
    if (xyz && codec_decode(dec, frame, len, xyz, floats, &got, &err) == CORE_OK &&
        (got.frame_len != len || got.seq != info.seq))
        __builtin_trap();
    free(xyz);
    free(frame);
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
