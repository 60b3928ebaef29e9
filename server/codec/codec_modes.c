/* codec: the candidate residuals of the modes the encoder tries on a group's strands and their
 * estimated bit costs. */
#include "codec_simd.h"

/* 0 for r = 0, else floor(log2 |r|) + 1, from the float32 exponent of |r| (rounded conversion,
 * as the vector path). */
static inline uint32_t cost_one(int32_t r)
{
    uint32_t m = r < 0 ? 0u - (uint32_t)r : (uint32_t)r;
    union { float f; uint32_t u; } v = { .f = (float)(int32_t)m };
    uint32_t e = v.u >> 23;
    return e > 126u ? e - 126u : 0u;
}

/* The vector path's loop with the 8 lanes as an inner loop (which compilers vectorise). */
static void costs_portable(const int32_t *P, const int32_t *X, uint32_t nv, bool key,
                           uint32_t cost[CODEC_CANDS * CODEC_GROUP], int32_t *cand)
{
    uint32_t c[CODEC_CANDS][CODEC_GROUP] = { { 0 } };
    for (uint32_t a = 0; a < 3; a++) {
        int32_t p1[CODEC_GROUP], x1[CODEC_GROUP], dp1[CODEC_GROUP], dp2[CODEC_GROUP], r0p[CODEC_GROUP];
        for (uint32_t l = 0; l < CODEC_GROUP; l++) {
            p1[l] = P[CODEC_GAT(1, a, l)];
            x1[l] = X[CODEC_GAT(1, a, l)];
            dp1[l] = dp2[l] = p1[l] - P[CODEC_GAT(0, a, l)];
            r0p[l] = dp1[l] - (x1[l] - X[CODEC_GAT(0, a, l)]);
            for (uint32_t m = 0; m < CODEC_CANDS; m++) cand[CODEC_CAT(1, a, m, l)] = r0p[l];
        }
        for (uint32_t v = 2; v < nv; v++)
            for (uint32_t l = 0; l < CODEC_GROUP; l++) {
                int32_t p0 = P[CODEC_GAT(v, a, l)], x0 = X[CODEC_GAT(v, a, l)];
                int32_t dp0 = p0 - p1[l], r0 = dp0 - (x0 - x1[l]), lin = dp0 - dp1[l];
                int32_t r[CODEC_CANDS];
                if (key) {
                    r[0] = lin;
                    r[1] = r0;
                    r[2] = v == 2u ? lin : dp0 - codec_half(dp1[l] + dp2[l]);
                } else {
                    r[0] = r0;
                    r[1] = r0 - r0p[l];
                    r[2] = lin;
                }
                for (uint32_t m = 0; m < CODEC_CANDS; m++) {
                    cand[CODEC_CAT(v, a, m, l)] = r[m];
                    c[m][l] += cost_one(r[m]);
                }
                dp2[l] = dp1[l];
                dp1[l] = dp0;
                r0p[l] = r0;
                p1[l] = p0;
                x1[l] = x0;
            }
    }
    for (uint32_t m = 0; m < CODEC_CANDS; m++)
        for (uint32_t l = 0; l < CODEC_GROUP; l++) cost[m * CODEC_GROUP + l] = c[m][l];
}

#ifdef __AVX2__
/* Per axis, vertex by vertex, the segments carried in registers; the candidates stored, per lane
 * the exponent fields of every mode summed and the bias taken off at the end. */
static inline void st_cand(int32_t *cand, uint32_t v, uint32_t a, uint32_t m, __m256i r)
{
    _mm256_storeu_si256((__m256i *)(void *)(cand + CODEC_CAT(v, a, m, 0)), r);
}

static inline __attribute__((always_inline)) void costs_avx2(const int32_t *P, const int32_t *X, uint32_t nv, const bool key,
                                                             uint32_t cost[CODEC_CANDS * CODEC_GROUP], int32_t *cand)
{
    __m256i c0 = _mm256_setzero_si256(), c1 = c0, c2 = c0;
    for (uint32_t a = 0; a < 3; a++) {
        __m256i p1 = codec_ldg(P, 1, a), x1 = codec_ldg(X, 1, a);
        __m256i dp1 = _mm256_sub_epi32(p1, codec_ldg(P, 0, a)), dx1 = _mm256_sub_epi32(x1, codec_ldg(X, 0, a));
        __m256i r0p = _mm256_sub_epi32(dp1, dx1), dp2 = dp1;
        for (uint32_t m = 0; m < CODEC_CANDS; m++) st_cand(cand, 1, a, m, r0p);
        for (uint32_t v = 2; v < nv; v++) {
            __m256i p0 = codec_ldg(P, v, a), x0 = codec_ldg(X, v, a);
            __m256i dp0 = _mm256_sub_epi32(p0, p1), dx0 = _mm256_sub_epi32(x0, x1);
            __m256i r0 = _mm256_sub_epi32(dp0, dx0), lin = _mm256_sub_epi32(dp0, dp1), m0, m1, m2;
            if (key) {
                m0 = lin;
                m1 = r0;
                m2 = v == 2u ? lin : _mm256_sub_epi32(dp0, codec_half8(_mm256_add_epi32(dp1, dp2)));
            } else {
                m0 = r0;
                m1 = _mm256_sub_epi32(r0, r0p);
                m2 = lin;
            }
            st_cand(cand, v, a, 0, m0);
            st_cand(cand, v, a, 1, m1);
            st_cand(cand, v, a, 2, m2);
            c0 = _mm256_add_epi32(c0, codec_log8(m0));
            c1 = _mm256_add_epi32(c1, codec_log8(m1));
            c2 = _mm256_add_epi32(c2, codec_log8(m2));
            dp2 = dp1;
            dp1 = dp0;
            r0p = r0;
            p1 = p0;
            x1 = x0;
        }
    }
    const __m256i bias = _mm256_set1_epi32((int32_t)(126u * 3u * (nv > 2 ? nv - 2u : 0u)));
    _mm256_storeu_si256((__m256i *)(void *)cost, _mm256_sub_epi32(c0, bias));
    _mm256_storeu_si256((__m256i *)(void *)(cost + CODEC_GROUP), _mm256_sub_epi32(c1, bias));
    _mm256_storeu_si256((__m256i *)(void *)(cost + 2u * CODEC_GROUP), _mm256_sub_epi32(c2, bias));
}
#endif

void codec_costs_group(const int32_t *P, const int32_t *X, uint32_t nv, bool key, uint32_t cost[CODEC_CANDS * CODEC_GROUP],
                       int32_t *cand, bool portable)
{
#ifdef __AVX2__
    if (!portable) {
        if (key)
            costs_avx2(P, X, nv, true, cost, cand);
        else
            costs_avx2(P, X, nv, false, cost, cand);
        return;
    }
#endif
    (void)portable;
    costs_portable(P, X, nv, key, cost, cand);
}
