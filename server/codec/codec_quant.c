/* codec: quantisation of one strand to the lattice with the float32 error check (fast path,
 * careful path, and the root alone for the motion estimate). */
#include <math.h>

#ifdef __AVX2__
#include <immintrin.h>
#endif

#include "codec_enc.h"

#define SHIFT ((double)(2 * CODEC_MAX_QUANT))

void codec_quant_setup(codec_quant *qz, float bound)
{
    qz->step = codec_step_for_bound(bound);
    qz->inv = 1.0 / qz->step;
    qz->bound = bound;
    qz->xlim = (float)((double)(CODEC_MAX_QUANT - 4) * qz->step);
    /* For |x| <= xsafe = 2^18 bound the fast path's q = floor(x / step + 1/2) always passes the
     * float32 check, so the check is skipped there: x / step and the shifted sum are each rounded
     * by at most 2^-26 (units of step), so |q step - x| <= step (1/2 + 2^-25) < bound (1 - 2^-5 + 2^-25);
     * rounding q step to binary64, then to binary32, adds at most (2^-24 + 2^-53) (|x| + step)
     * < bound (2^-6 + 2^-22); the sum stays below bound. */
    qz->xsafe = (float)ldexp((double)bound, 18);
}

/* One coordinate on the fast path: truncation of a shifted positive value, i.e. floor(t + 1/2);
 * false when out of range or when the float32 reconstruction misses the bound. */
static inline bool fast_one(const codec_quant *qz, float x, int32_t *q)
{
    if (!(fabsf(x) <= qz->xlim)) return false;
    int32_t v = (int32_t)((double)x * qz->inv + (SHIFT + 0.5)) - 2 * CODEC_MAX_QUANT;
    *q = v;
    return fabsf(x) <= qz->xsafe || !(fabsf((float)((double)v * qz->step) - x) > qz->bound);
}

static uint32_t group_portable(const codec_quant *qz, const float *const src[CODEC_GROUP], uint32_t nv, int32_t *P)
{
    uint32_t bad = 0;
    for (uint32_t l = 0; l < CODEC_GROUP; l++) {
        bool ok = true;
        for (uint32_t v = 0; v < nv; v++)
            for (uint32_t a = 0; a < 3; a++) ok &= fast_one(qz, src[l][3u * v + a], &P[CODEC_GAT(v, a, l)]);
        bad |= (uint32_t)!ok << l;
    }
    return bad;
}

#ifdef __AVX2__
/* Constants of the vector path. */
typedef struct quant8 {
    __m256d inv, step, shift, two_max;
    __m256 absmask, xlim, bound, xsafe;
} quant8;

/* 4 coordinates: the lattice values of fast_one (floor of the shifted value, then the shift
 * taken off exactly in binary64); lanes whose float32 reconstruction misses the bound are set
 * in the returned mask. */
static inline __m128i fast4(const quant8 *k, __m128 x, __m128 *bad)
{
    __m256d q = _mm256_sub_pd(_mm256_round_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_cvtps_pd(x), k->inv), k->shift),
                                              _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC),
                              k->two_max);
    __m128 err = _mm_and_ps(_mm_sub_ps(_mm256_cvtpd_ps(_mm256_mul_pd(q, k->step)), x), _mm256_castps256_ps128(k->absmask));
    *bad = _mm_cmp_ps(err, _mm256_castps256_ps128(k->bound), _CMP_GT_OQ);
    return _mm256_cvttpd_epi32(q);
}

/* 8 coordinates (one axis of the group's 8 strands): the range check, then two halves. */
static inline __m256i fast8(const quant8 *k, __m256 x, __m256 *bad)
{
    __m128 blo, bhi;
    __m128i qlo = fast4(k, _mm256_castps256_ps128(x), &blo), qhi = fast4(k, _mm256_extractf128_ps(x, 1), &bhi);
    *bad = _mm256_or_ps(*bad, _mm256_or_ps(_mm256_cmp_ps(_mm256_and_ps(x, k->absmask), k->xlim, _CMP_NLE_UQ),
                                           _mm256_set_m128(bhi, blo)));
    return _mm256_set_m128i(qhi, qlo);
}

/* 8 coordinates without the float32 check: the lattice values (the same as fast4's), lanes
 * beyond xsafe (or NaN) set in the mask. */
static inline __m256i quick8(const quant8 *k, __m256 x, __m256 *big)
{
    const __m256d off = _mm256_set1_pd(SHIFT + 0.5);
    __m128i lo = _mm256_cvttpd_epi32(_mm256_add_pd(_mm256_mul_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(x)), k->inv), off));
    __m128i hi = _mm256_cvttpd_epi32(_mm256_add_pd(_mm256_mul_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(x, 1)), k->inv), off));
    *big = _mm256_or_ps(*big, _mm256_cmp_ps(_mm256_and_ps(x, k->absmask), k->xsafe, _CMP_NLE_UQ));
    return _mm256_sub_epi32(_mm256_set_m128i(hi, lo), _mm256_set1_epi32(2 * CODEC_MAX_QUANT));
}

/* Four floats at p of strands l (low half) and l + 4 (high half). */
static inline __m256 load2(const float *lo, const float *hi)
{
    return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(lo)), _mm_loadu_ps(hi), 1);
}

/* Per vertex one 4-float load per strand (x y z of the vertex and the next x; the last vertex
 * loads from one float earlier) and a 4 x 4 transposition in each half. */
static inline __attribute__((always_inline)) uint32_t group_avx2(const quant8 *kp, const float *const src[CODEC_GROUP],
                                                                  uint32_t nv, int32_t *P, const bool check,
                                                                  const float *const *next)
{
    const quant8 k = *kp;
    const float *s0 = src[0], *s1 = src[1], *s2 = src[2], *s3 = src[3], *s4 = src[4], *s5 = src[5], *s6 = src[6],
                *s7 = src[7];
    __m256 bad = _mm256_setzero_ps();
    for (uint32_t v = 0; v < nv; v++) {
        if (next && (12u * v & 63u) < 12u) /* the next group's strands, a cache line at a time */
            for (uint32_t l = 0; l < CODEC_GROUP; l++) __builtin_prefetch(next[l] + 3u * v);
        /* the last vertex: read x y z ending at its z (element 1..3) */
        const size_t o = 3u * (size_t)v - (v + 1u == nv);
        __m256 r0 = load2(s0 + o, s4 + o), r1 = load2(s1 + o, s5 + o), r2 = load2(s2 + o, s6 + o),
               r3 = load2(s3 + o, s7 + o);
        __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpackhi_ps(r0, r1), t2 = _mm256_unpacklo_ps(r2, r3),
               t3 = _mm256_unpackhi_ps(r2, r3);
        __m256 e0 = _mm256_shuffle_ps(t0, t2, 0x44), e1 = _mm256_shuffle_ps(t0, t2, 0xee),
               e2 = _mm256_shuffle_ps(t1, t3, 0x44), e3 = _mm256_shuffle_ps(t1, t3, 0xee);
        __m256 x = e0, y = e1, z = e2;
        if (v + 1u == nv) {
            x = e1;
            y = e2;
            z = e3;
        }
        int32_t *q = P + (size_t)v * CODEC_GSTRIDE;
        if (check) {
            _mm256_storeu_si256((__m256i *)(void *)q, fast8(&k, x, &bad));
            _mm256_storeu_si256((__m256i *)(void *)(q + CODEC_GROUP), fast8(&k, y, &bad));
            _mm256_storeu_si256((__m256i *)(void *)(q + 2u * CODEC_GROUP), fast8(&k, z, &bad));
        } else {
            _mm256_storeu_si256((__m256i *)(void *)q, quick8(&k, x, &bad));
            _mm256_storeu_si256((__m256i *)(void *)(q + CODEC_GROUP), quick8(&k, y, &bad));
            _mm256_storeu_si256((__m256i *)(void *)(q + 2u * CODEC_GROUP), quick8(&k, z, &bad));
        }
    }
    return (uint32_t)_mm256_movemask_ps(bad);
}

/* Without the float32 check while every coordinate is within xsafe (the common case), else
 * again with it. */
static uint32_t group_avx2_any(const codec_quant *qz, const float *const src[CODEC_GROUP], uint32_t nv, int32_t *P,
                               const float *const *next)
{
    const quant8 k = {
        .inv = _mm256_set1_pd(qz->inv), .step = _mm256_set1_pd(qz->step), .shift = _mm256_set1_pd(SHIFT + 0.5),
        .two_max = _mm256_set1_pd(SHIFT), .absmask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff)),
        .xlim = _mm256_set1_ps(qz->xlim), .bound = _mm256_set1_ps(qz->bound), .xsafe = _mm256_set1_ps(qz->xsafe),
    };
    if (!group_avx2(&k, src, nv, P, false, next)) return 0;
    return group_avx2(&k, src, nv, P, true, NULL);
}
#endif

uint32_t codec_quant_group(const codec_quant *qz, const float *const src[CODEC_GROUP], uint32_t nv, int32_t *P,
                           const float *const *next, bool portable)
{
#ifdef __AVX2__
    if (!portable) return group_avx2_any(qz, src, nv, P, next);
#endif
    (void)portable;
    (void)next;
    return group_portable(qz, src, nv, P);
}

/* The nearest lattice point whose float32 reconstruction is within the bound (the nearest one
 * or a neighbour). */
static core_status careful_one(const codec_quant *qz, float x, uint32_t strand, uint32_t vert, int32_t *out,
                               core_err *err)
{
    const double t = (double)x * qz->inv;
    if (!(fabs(t) < (double)(CODEC_MAX_QUANT - 2)))
        return core_fail(err, CORE_EINVAL, "codec: strand %u vertex %u coordinate %g is %s", strand, vert, (double)x,
                         isfinite(x) ? "out of range for this error bound" : "not finite");
    int32_t v = (int32_t)lrint(t);
    if (!(fabsf((float)((double)v * qz->step) - x) <= qz->bound)) {
        int32_t alt = (float)((double)v * qz->step) < x ? v + 1 : v - 1;
        if (!(fabsf((float)((double)alt * qz->step) - x) <= qz->bound))
            return core_fail(err, CORE_EINVAL, "codec: coordinate %g cannot be held within %g m in float32", (double)x,
                             (double)qz->bound);
        v = alt;
    }
    *out = v;
    return CORE_OK;
}

core_status codec_quant_careful(const codec_quant *qz, const float *src, uint32_t nv, int32_t *P, uint32_t l,
                                uint32_t strand, core_err *err)
{
    for (uint32_t v = 0; v < nv; v++)
        for (uint32_t a = 0; a < 3; a++) {
            core_status st = careful_one(qz, src[3u * v + a], strand, v, &P[CODEC_GAT(v, a, l)], err);
            if (st) return st;
        }
    return CORE_OK;
}

bool codec_quant_root(const codec_quant *qz, const float *src, int32_t q[3])
{
    for (uint32_t a = 0; a < 3; a++) {
        /* the fast value passes its check and equals the careful path's first choice, so both
         * paths give it */
        if (!fast_one(qz, src[a], &q[a]) || lrint((double)src[a] * qz->inv) != q[a]) return false;
    }
    return true;
}
