/* codec: CRC-32 of zlib (reflected polynomial 0xEDB88320) by carry-less multiplication folding
 * where PCLMULQDQ is available, zlib's crc32 otherwise and for short pieces. */
#include <zlib.h>

#if defined(__PCLMUL__) && defined(__SSE4_1__)
#include <immintrin.h>
#endif

#include "codec_internal.h"

/* zlib's crc32 over any length (it takes uInt lengths). */
static uint32_t crc_zlib(uint32_t crc, const uint8_t *p, size_t n)
{
    uLong c = crc;
    while (n > 0) {
        uInt k = n > (1u << 30) ? (1u << 30) : (uInt)n;
        c = crc32(c, p, k);
        p += k;
        n -= k;
    }
    return (uint32_t)c;
}

#if defined(__PCLMUL__) && defined(__SSE4_1__)
/* Folding constants for the bit-reflected polynomial (x^k mod P, reflected, k per use below):
 * 4 x 128 bits at a time, 128 bits at a time, 64 -> 32 bits, then Barrett reduction with P' and
 * u' = floor(x^64 / P)'. Checked against zlib by the tests. */
static inline __m128i fold(__m128i x, __m128i k, __m128i data)
{
    return _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x, k, 0x00), _mm_clmulepi64_si128(x, k, 0x11)), data);
}

static uint32_t crc_fold(uint32_t crc, const uint8_t *p, size_t n)
{
    const __m128i k512 = _mm_set_epi64x(0x1c6e41596ll, 0x154442bd4ll), k128 = _mm_set_epi64x(0x0ccaa009ell, 0x1751997d0ll);
    __m128i x0 = _mm_loadu_si128((const __m128i *)(const void *)p), x1 = _mm_loadu_si128((const __m128i *)(const void *)(p + 16)),
            x2 = _mm_loadu_si128((const __m128i *)(const void *)(p + 32)), x3 = _mm_loadu_si128((const __m128i *)(const void *)(p + 48));
    x0 = _mm_xor_si128(x0, _mm_cvtsi32_si128((int)~crc));
    p += 64;
    n -= 64;
    for (; n >= 64; p += 64, n -= 64) {
        x0 = fold(x0, k512, _mm_loadu_si128((const __m128i *)(const void *)p));
        x1 = fold(x1, k512, _mm_loadu_si128((const __m128i *)(const void *)(p + 16)));
        x2 = fold(x2, k512, _mm_loadu_si128((const __m128i *)(const void *)(p + 32)));
        x3 = fold(x3, k512, _mm_loadu_si128((const __m128i *)(const void *)(p + 48)));
    }
    x0 = fold(fold(fold(x0, k128, x1), k128, x2), k128, x3);
    for (; n >= 16; p += 16, n -= 16) x0 = fold(x0, k128, _mm_loadu_si128((const __m128i *)(const void *)p));
    const __m128i mask32 = _mm_set_epi32(0, 0, 0, -1), k64 = _mm_set_epi64x(0, 0x163cd6124ll),
                  pu = _mm_set_epi64x(0x1f7011641ll, 0x1db710641ll);
    __m128i t = _mm_xor_si128(_mm_clmulepi64_si128(x0, k128, 0x10), _mm_srli_si128(x0, 8));            /* 128 -> 64 */
    t = _mm_xor_si128(_mm_clmulepi64_si128(_mm_and_si128(t, mask32), k64, 0x00), _mm_srli_si128(t, 4)); /* 64 -> 32 */
    __m128i b = _mm_and_si128(_mm_clmulepi64_si128(_mm_and_si128(t, mask32), pu, 0x10), mask32);
    b = _mm_xor_si128(_mm_clmulepi64_si128(b, pu, 0x00), t);
    uint32_t c = ~(uint32_t)_mm_extract_epi32(b, 1);
    return n ? crc_zlib(c, p, n) : c;
}
#endif

uint32_t codec_crc32(uint32_t crc, const uint8_t *p, size_t n)
{
#if defined(__PCLMUL__) && defined(__SSE4_1__)
    if (n >= 64) return crc_fold(crc, p, n);
#endif
    return crc_zlib(crc, p, n);
}
