/* codec: the estimated bit costs of a strand's candidate predictions (residual kinds). */
#include "codec_simd.h"

/* floor(log2(2 |r| + 1)) as the float32 exponent (rounded conversion, as the vector path). */
static inline uint32_t cost_one(int32_t r)
{
    uint32_t m = r < 0 ? 0u - (uint32_t)r : (uint32_t)r;
    union { float f; uint32_t u; } v = { .f = (float)(int32_t)(2u * m + 1u) };
    return (v.u >> 23) - 127u;
}

static void costs_portable(const int32_t *const P[3], const int32_t *const X[3], uint32_t nv, bool with_kind1,
                           uint32_t cost[CODEC_KINDS])
{
    for (uint32_t k = 0; k < CODEC_KINDS; k++) {
        cost[k] = 0;
        if (k == 1u && !with_kind1) continue;
        for (uint32_t a = 0; a < 3; a++)
            for (uint32_t v = 2; v < nv; v++) cost[k] += cost_one(codec_kind_one(k, P[a], X[a], v));
    }
}

#ifdef __AVX2__
static inline uint32_t hsum8(__m256i v)
{
    __m128i s = _mm_add_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
    s = _mm_add_epi32(s, _mm_shuffle_epi32(s, 0x4e));
    s = _mm_add_epi32(s, _mm_shuffle_epi32(s, 0xb1));
    return (uint32_t)_mm_cvtsi128_si32(s);
}

/* Every lane contributes its exponent field; lanes outside vertices 2..nv-1 have r = 0, i.e.
 * exactly the bias 127, taken off at the end. */
static void costs_avx2(const int32_t *const P[3], const int32_t *const X[3], uint32_t nv, bool with_kind1,
                       uint32_t cost[CODEC_KINDS])
{
    __m256i c0 = _mm256_setzero_si256(), c1 = c0, c2 = c0, c3 = c0;
    uint32_t lanes = 0;
    for (uint32_t a = 0; a < 3; a++) {
        const int32_t *p = P[a], *x = X[a];
        for (uint32_t v0 = 0; v0 < nv; v0 += CODEC_LANES, lanes += CODEC_LANES) {
            codec_seg8 s = codec_segments8(p, x, v0);
            __m256i r0 = codec_kind0_8(&s), r1 = codec_kind1_8(&s), r2 = codec_kind2_8(&s), r3 = codec_kind3_8(&s, v0);
            if (v0 == 0 || v0 + CODEC_LANES > nv) {
                __m256i ok = codec_lanes8(v0, 2, nv);
                r0 = _mm256_and_si256(r0, ok);
                r1 = _mm256_and_si256(r1, ok);
                r2 = _mm256_and_si256(r2, ok);
                r3 = _mm256_and_si256(r3, ok);
            }
            c0 = _mm256_add_epi32(c0, codec_log8(r0));
            if (with_kind1) c1 = _mm256_add_epi32(c1, codec_log8(r1));
            c2 = _mm256_add_epi32(c2, codec_log8(r2));
            c3 = _mm256_add_epi32(c3, codec_log8(r3));
        }
    }
    cost[0] = hsum8(c0) - 127u * lanes;
    cost[1] = with_kind1 ? hsum8(c1) - 127u * lanes : 0;
    cost[2] = hsum8(c2) - 127u * lanes;
    cost[3] = hsum8(c3) - 127u * lanes;
}
#endif

void codec_kind_costs(const int32_t *const P[3], const int32_t *const X[3], uint32_t nv, bool with_kind1,
                      uint32_t cost[CODEC_KINDS], bool portable)
{
#ifdef __AVX2__
    if (!portable) {
        costs_avx2(P, X, nv, with_kind1, cost);
        return;
    }
#endif
    (void)portable;
    costs_portable(P, X, nv, with_kind1, cost);
}
