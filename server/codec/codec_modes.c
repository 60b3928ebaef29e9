/* codec: the candidate predictions of a strand's vertices (residual kinds), their estimated
 * bit costs and the residual rows of the chosen one. */
#include <string.h>

#ifdef __AVX2__
#include <immintrin.h>
#endif

#include "codec_enc.h"

/* floor(log2(2 |r| + 1)) as the float32 exponent (rounded conversion, as the vector path). */
static inline uint32_t cost_one(int32_t r)
{
    uint32_t m = r < 0 ? 0u - (uint32_t)r : (uint32_t)r;
    union { float f; uint32_t u; } v = { .f = (float)(int32_t)(2u * m + 1u) };
    return (v.u >> 23) - 127u;
}

/* Residual of kind k at lane v >= 2 of one row (p = P row, x = X row). */
static inline int32_t kind_one(uint32_t kind, const int32_t *p, const int32_t *x, uint32_t v)
{
    int32_t dp0 = p[v] - p[v - 1], dp1 = p[v - 1] - p[v - 2];
    switch (kind) {
    case 0:
        return dp0 - (x[v] - x[v - 1]);
    case 1:
        return dp0 - (x[v] - x[v - 1]) - (dp1 - (x[v - 1] - x[v - 2]));
    case 2:
        return dp0 - dp1;
    default:
        return v == 2u ? dp0 - dp1 : dp0 - codec_half(dp1 + (p[v - 2] - p[v - 3]));
    }
}

static void costs_portable(const int32_t *const P[3], const int32_t *const X[3], uint32_t nv, bool with_kind1,
                           uint32_t cost[CODEC_KINDS])
{
    for (uint32_t k = 0; k < CODEC_KINDS; k++) {
        cost[k] = 0;
        if (k == 1u && !with_kind1) continue;
        for (uint32_t a = 0; a < 3; a++)
            for (uint32_t v = 2; v < nv; v++) cost[k] += cost_one(kind_one(k, P[a], X[a], v));
    }
}

static void residuals_portable(uint32_t kind, const int32_t *const P[3], const int32_t *const X[3], uint32_t nv,
                               int32_t *const R[3])
{
    for (uint32_t a = 0; a < 3; a++) {
        const int32_t *p = P[a], *x = X[a];
        R[a][1] = (p[1] - p[0]) - (x[1] - x[0]);
        for (uint32_t v = 2; v < nv; v++) R[a][v] = kind_one(kind, p, x, v);
        for (uint32_t v = nv; v < codec_lanes_round(nv); v++) R[a][v] = 0;
    }
}

#ifdef __AVX2__
#define LD(p) _mm256_loadu_si256((const __m256i *)(const void *)(p))

/* The four kinds for lanes v0..v0+7 of one row. */
static inline void kinds8(const int32_t *p, const int32_t *x, uint32_t v0, __m256i r[CODEC_KINDS])
{
    __m256i a0 = LD(p + v0), a1 = LD(p + v0 - 1), a2 = LD(p + v0 - 2), a3 = LD(p + v0 - 3);
    __m256i b0 = LD(x + v0), b1 = LD(x + v0 - 1), b2 = LD(x + v0 - 2);
    __m256i dp0 = _mm256_sub_epi32(a0, a1), dp1 = _mm256_sub_epi32(a1, a2), dp2 = _mm256_sub_epi32(a2, a3);
    __m256i dx0 = _mm256_sub_epi32(b0, b1), dx1 = _mm256_sub_epi32(b1, b2);
    __m256i s = _mm256_add_epi32(dp1, dp2);
    __m256i half = _mm256_srai_epi32(
        _mm256_add_epi32(s, _mm256_and_si256(_mm256_srai_epi32(s, 1), _mm256_set1_epi32(1))), 1);
    r[0] = _mm256_sub_epi32(dp0, dx0);
    r[1] = _mm256_sub_epi32(r[0], _mm256_sub_epi32(dp1, dx1));
    r[2] = _mm256_sub_epi32(dp0, dp1);
    r[3] = _mm256_sub_epi32(dp0, half);
    if (v0 == 0) r[3] = _mm256_blend_epi32(r[3], r[2], 0x04); /* v = 2: linear */
}

/* Float32 exponent fields (biased) of 2 |r| + 1. */
static inline __m256i cost8(__m256i r)
{
    __m256i m = _mm256_abs_epi32(r);
    __m256i t = _mm256_or_si256(_mm256_add_epi32(m, m), _mm256_set1_epi32(1));
    return _mm256_srli_epi32(_mm256_castps_si256(_mm256_cvtepi32_ps(t)), 23);
}

/* Lanes v0..v0+7 that hold vertices 2..nv-1. */
static inline __m256i valid8(uint32_t v0, uint32_t nv)
{
    __m256i idx = _mm256_add_epi32(_mm256_set1_epi32((int32_t)v0), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    return _mm256_and_si256(_mm256_cmpgt_epi32(idx, _mm256_set1_epi32(1)),
                            _mm256_cmpgt_epi32(_mm256_set1_epi32((int32_t)nv), idx));
}

/* Lanes v0..v0+7 below nv. */
static inline __m256i below8(uint32_t v0, uint32_t nv)
{
    __m256i idx = _mm256_add_epi32(_mm256_set1_epi32((int32_t)v0), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    return _mm256_cmpgt_epi32(_mm256_set1_epi32((int32_t)nv), idx);
}

static inline uint32_t hsum8(__m256i v)
{
    __m128i s = _mm_add_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
    s = _mm_add_epi32(s, _mm_shuffle_epi32(s, 0x4e));
    s = _mm_add_epi32(s, _mm_shuffle_epi32(s, 0xb1));
    return (uint32_t)_mm_cvtsi128_si32(s);
}

static void costs_avx2(const int32_t *const P[3], const int32_t *const X[3], uint32_t nv, bool with_kind1,
                       uint32_t cost[CODEC_KINDS])
{
    __m256i acc[CODEC_KINDS];
    for (uint32_t k = 0; k < CODEC_KINDS; k++) acc[k] = _mm256_setzero_si256();
    uint32_t lanes = 0;
    for (uint32_t a = 0; a < 3; a++)
        for (uint32_t v0 = 0; v0 < nv; v0 += CODEC_LANES) {
            __m256i r[CODEC_KINDS];
            kinds8(P[a], X[a], v0, r);
            if (v0 == 0 || v0 + CODEC_LANES > nv) { /* masked lanes: r = 0, exponent field 127 */
                __m256i ok = valid8(v0, nv);
                for (uint32_t k = 0; k < CODEC_KINDS; k++) r[k] = _mm256_and_si256(r[k], ok);
            }
            acc[0] = _mm256_add_epi32(acc[0], cost8(r[0]));
            if (with_kind1) acc[1] = _mm256_add_epi32(acc[1], cost8(r[1]));
            acc[2] = _mm256_add_epi32(acc[2], cost8(r[2]));
            acc[3] = _mm256_add_epi32(acc[3], cost8(r[3]));
            lanes += CODEC_LANES;
        }
    for (uint32_t k = 0; k < CODEC_KINDS; k++) cost[k] = hsum8(acc[k]) - 127u * lanes;
    if (!with_kind1) cost[1] = 0;
}

static void residuals_avx2(uint32_t kind, const int32_t *const P[3], const int32_t *const X[3], uint32_t nv,
                           int32_t *const R[3])
{
    for (uint32_t a = 0; a < 3; a++) {
        for (uint32_t v0 = 0; v0 < nv; v0 += CODEC_LANES) {
            __m256i r[CODEC_KINDS];
            kinds8(P[a], X[a], v0, r);
            __m256i out = r[kind];
            if (v0 == 0) out = _mm256_blend_epi32(out, r[0], 0x02); /* vertex 1: dP - dX */
            if (v0 + CODEC_LANES > nv) out = _mm256_and_si256(out, below8(v0, nv));
            _mm256_storeu_si256((__m256i *)(void *)(R[a] + v0), out);
        }
    }
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

void codec_kind_residuals(uint32_t kind, const int32_t *const P[3], const int32_t *const X[3], uint32_t nv,
                          int32_t *const R[3], bool portable)
{
#ifdef __AVX2__
    if (!portable) {
        residuals_avx2(kind, P, X, nv, R);
        return;
    }
#endif
    (void)portable;
    residuals_portable(kind, P, X, nv, R);
}
