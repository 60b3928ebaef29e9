/* codec: AVX2 building blocks shared by the encoder kernels (residual kinds of 8 vertices,
 * magnitude classes and raw fields); only with __AVX2__. */
#ifndef CODEC_CODEC_SIMD_H
#define CODEC_CODEC_SIMD_H

#ifdef __AVX2__
#include <immintrin.h>

#include "codec_enc.h"

static inline __m256i codec_ld8(const int32_t *p)
{
    return _mm256_loadu_si256((const __m256i *)(const void *)p);
}

static inline void codec_st8(int32_t *p, __m256i v)
{
    _mm256_storeu_si256((__m256i *)(void *)p, v);
}

/* Segments of lanes v0..v0+7 of one row p (p[v] - p[v-1], then one and two lanes earlier) and
 * of the reference row x. */
typedef struct codec_seg8 {
    __m256i dp0, dp1, dp2, dx0, dx1;
} codec_seg8;

static inline codec_seg8 codec_segments8(const int32_t *p, const int32_t *x, uint32_t v0)
{
    __m256i a1 = codec_ld8(p + v0 - 1), a2 = codec_ld8(p + v0 - 2), b1 = codec_ld8(x + v0 - 1);
    codec_seg8 s = {
        .dp0 = _mm256_sub_epi32(codec_ld8(p + v0), a1), .dp1 = _mm256_sub_epi32(a1, a2),
        .dp2 = _mm256_sub_epi32(a2, codec_ld8(p + v0 - 3)), .dx0 = _mm256_sub_epi32(codec_ld8(x + v0), b1),
        .dx1 = _mm256_sub_epi32(b1, codec_ld8(x + v0 - 2)),
    };
    return s;
}

/* Residual kinds 0..3 (codec_enc.h) from the segments; lanes 0 and 1 of the first block are
 * not meaningful (vertex 2 of kind 3 is linear). */
static inline __m256i codec_kind0_8(const codec_seg8 *s)
{
    return _mm256_sub_epi32(s->dp0, s->dx0);
}

static inline __m256i codec_kind1_8(const codec_seg8 *s)
{
    return _mm256_sub_epi32(_mm256_sub_epi32(s->dp0, s->dx0), _mm256_sub_epi32(s->dp1, s->dx1));
}

static inline __m256i codec_kind2_8(const codec_seg8 *s)
{
    return _mm256_sub_epi32(s->dp0, s->dp1);
}

static inline __m256i codec_kind3_8(const codec_seg8 *s, uint32_t v0)
{
    __m256i d = _mm256_add_epi32(s->dp1, s->dp2);
    __m256i half = _mm256_srai_epi32(_mm256_add_epi32(d, _mm256_and_si256(_mm256_srai_epi32(d, 1), _mm256_set1_epi32(1))), 1);
    __m256i r = _mm256_sub_epi32(s->dp0, half);
    return v0 == 0 ? _mm256_blend_epi32(r, codec_kind2_8(s), 0x04) : r; /* vertex 2: linear */
}

static inline __m256i codec_kind8(uint32_t kind, const codec_seg8 *s, uint32_t v0)
{
    switch (kind) {
    case 0:
        return codec_kind0_8(s);
    case 1:
        return codec_kind1_8(s);
    case 2:
        return codec_kind2_8(s);
    default:
        return codec_kind3_8(s, v0);
    }
}

/* Lanes v0..v0+7 that are at least lo and below nv, as all-ones. */
static inline __m256i codec_lanes8(uint32_t v0, int32_t lo, uint32_t nv)
{
    __m256i idx = _mm256_add_epi32(_mm256_set1_epi32((int32_t)v0), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    return _mm256_and_si256(_mm256_cmpgt_epi32(idx, _mm256_set1_epi32(lo - 1)),
                            _mm256_cmpgt_epi32(_mm256_set1_epi32((int32_t)nv), idx));
}

/* Biased float32 exponent fields of 2 |r| + 1: floor(log2(2 |r| + 1)) + 127. */
static inline __m256i codec_log8(__m256i r)
{
    __m256i m = _mm256_abs_epi32(r);
    __m256i t = _mm256_or_si256(_mm256_add_epi32(m, m), _mm256_set1_epi32(1));
    return _mm256_srli_epi32(_mm256_castps_si256(_mm256_cvtepi32_ps(t)), 23);
}

#endif
#endif
