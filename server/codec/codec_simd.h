/* codec: AVX2 building blocks shared by the encoder's group kernels (loads of one axis of one
 * vertex of a group, residual kinds, float32 exponents); only with __AVX2__. */
#ifndef CODEC_CODEC_SIMD_H
#define CODEC_CODEC_SIMD_H

#include "codec_enc.h"

#ifdef __AVX2__
#include <immintrin.h>

/* Axis a of vertex v of the group G (all 8 strands). */
static inline __m256i codec_ldg(const int32_t *G, uint32_t v, uint32_t a)
{
    return _mm256_loadu_si256((const __m256i *)(const void *)(G + CODEC_GAT(v, a, 0)));
}

static inline void codec_stg(int32_t *G, uint32_t v, uint32_t a, __m256i x)
{
    _mm256_storeu_si256((__m256i *)(void *)(G + CODEC_GAT(v, a, 0)), x);
}

/* half(d) of codec_internal.h on 8 lanes. */
static inline __m256i codec_half8(__m256i d)
{
    return _mm256_srai_epi32(_mm256_add_epi32(d, _mm256_and_si256(_mm256_srai_epi32(d, 1), _mm256_set1_epi32(1))), 1);
}

/* The bit cost estimate of codec_enc.h (0 for r = 0, else floor(log2 |r|) + 1) plus 126: the
 * float32 exponent field of |r|, at least 126. */
static inline __m256i codec_log8(__m256i r)
{
    __m256i e = _mm256_srli_epi32(_mm256_castps_si256(_mm256_cvtepi32_ps(_mm256_abs_epi32(r))), 23);
    return _mm256_max_epi32(e, _mm256_set1_epi32(126));
}

#endif
#endif
