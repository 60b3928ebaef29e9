/* proto: what the binaries the server serves over HTTP share (/collider.bin, /groom.bin): their
 * header check and version tag. */
#include "proto.h"
#include "proto_bin.h"

void proto_bin_etag(const unsigned char *bin, size_t len, char out[17])
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < len; i++) h = (h ^ bin[i]) * 0x100000001b3ull;
    static const char hex[] = "0123456789abcdef";
    for (int i = 0; i < 16; i++) out[i] = hex[(h >> (60 - 4 * i)) & 15];
    out[16] = '\0';
}

core_status proto_bin_header(const unsigned char *bin, size_t len, const char *magic, uint32_t version,
                             const char *what, uint32_t *a, uint32_t *b, core_err *err)
{
    *a = *b = 0;
    if (len < 16 || memcmp(bin, magic, 4) != 0)
        return core_fail(err, CORE_EFORMAT, "%s: %zu bytes without the \"%s\" header", what, len, magic);
    uint32_t v = proto_bin_get_u32(bin + 4);
    if (v != version) return core_fail(err, CORE_EFORMAT, "%s: version %u, expected %u", what, v, version);
    *a = proto_bin_get_u32(bin + 8), *b = proto_bin_get_u32(bin + 12);
    return CORE_OK;
}
