/* proto: what the binaries served over HTTP (/collider.bin, /groom.bin) share: little-endian
 * fields and a header of magic, version and two counts. Internal to proto/. */
#ifndef PROTO_PROTO_BIN_H
#define PROTO_PROTO_BIN_H

#include <stdint.h>
#include <string.h>

#include "../core/core.h"

static inline void proto_bin_put_u32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i));
}

static inline uint32_t proto_bin_get_u32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static inline void proto_bin_put_f32(unsigned char *p, float f)
{
    uint32_t bits;
    memcpy(&bits, &f, 4);
    proto_bin_put_u32(p, bits);
}

static inline float proto_bin_get_f32(const unsigned char *p)
{
    uint32_t bits = proto_bin_get_u32(p);
    float f;
    memcpy(&f, &bits, 4);
    return f;
}

/* Checks a 16-byte header (4-byte magic, uint32 version, two uint32 counts) at the start of
 * bin (len bytes) against magic and version, and gives the counts; what names the binary in
 * the message ("collider mesh binary"). CORE_EFORMAT with the reason in err. Pure. */
core_status proto_bin_header(const unsigned char *bin, size_t len, const char *magic, uint32_t version,
                             const char *what, uint32_t *a, uint32_t *b, core_err *err);

#endif
