/* proto: the version tag of a binary the server serves over HTTP (/collider.bin, /groom.bin). */
#include "proto.h"

void proto_bin_etag(const unsigned char *bin, size_t len, char out[17])
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < len; i++) h = (h ^ bin[i]) * 0x100000001b3ull;
    static const char hex[] = "0123456789abcdef";
    for (int i = 0; i < 16; i++) out[i] = hex[(h >> (60 - 4 * i)) & 15];
    out[16] = '\0';
}
