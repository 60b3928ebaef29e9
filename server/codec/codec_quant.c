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
}

/* One coordinate on the fast path: truncation of a shifted positive value, i.e. floor(t + 1/2);
 * false when out of range or when the float32 reconstruction misses the bound. */
static inline bool fast_one(const codec_quant *qz, float x, int32_t *q)
{
    if (!(fabsf(x) <= qz->xlim)) return false;
    int32_t v = (int32_t)((double)x * qz->inv + (SHIFT + 0.5)) - 2 * CODEC_MAX_QUANT;
    *q = v;
    return !(fabsf((float)((double)v * qz->step) - x) > qz->bound);
}

static bool fast_portable(const codec_quant *qz, const float *src, uint32_t v0, uint32_t nv, int32_t *const rows[3])
{
    bool ok = true;
    for (uint32_t v = v0; v < nv; v++)
        for (uint32_t a = 0; a < 3; a++) ok &= fast_one(qz, src[3u * v + a], &rows[a][v]);
    return ok;
}

#ifdef __AVX2__
/* Constants of the vector path. */
typedef struct quant8 {
    __m256d inv, step, shift, two_max;
    __m256 absmask, xlim, bound;
} quant8;

/* 4 coordinates: the lattice values of fast_one (floor of the shifted value, then the shift
 * taken off exactly in binary64), and the lanes that failed (range or bound) or'ed into *bad. */
static inline __m128i fast4(const quant8 *k, __m128 x, __m256d xd, __m128 *bad)
{
    __m256d q = _mm256_sub_pd(_mm256_round_pd(_mm256_add_pd(_mm256_mul_pd(xd, k->inv), k->shift),
                                              _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC),
                              k->two_max);
    __m128 err = _mm_and_ps(_mm_sub_ps(_mm256_cvtpd_ps(_mm256_mul_pd(q, k->step)), x), _mm256_castps256_ps128(k->absmask));
    *bad = _mm_or_ps(*bad, _mm_cmp_ps(err, _mm256_castps256_ps128(k->bound), _CMP_GT_OQ));
    return _mm256_cvttpd_epi32(q);
}

/* 8 coordinates: the range check, then two halves. */
static inline __m256i fast8(const quant8 *k, __m256 x, __m256 *bad)
{
    *bad = _mm256_or_ps(*bad, _mm256_cmp_ps(_mm256_and_ps(x, k->absmask), k->xlim, _CMP_NLE_UQ));
    __m128 lo = _mm256_castps256_ps128(x), hi = _mm256_extractf128_ps(x, 1), blo = _mm_setzero_ps(), bhi = blo;
    __m128i qlo = fast4(k, lo, _mm256_cvtps_pd(lo), &blo), qhi = fast4(k, hi, _mm256_cvtps_pd(hi), &bhi);
    *bad = _mm256_or_ps(*bad, _mm256_set_m128(bhi, blo));
    return _mm256_set_m128i(qhi, qlo);
}

/* 8 vertices at a time: three loads of xyz, de-interleaved into x, y and z by blends and lane
 * permutations. */
static bool fast_avx2(const codec_quant *qz, const float *src, uint32_t nv, int32_t *const rows[3])
{
    const quant8 k = {
        .inv = _mm256_set1_pd(qz->inv), .step = _mm256_set1_pd(qz->step), .shift = _mm256_set1_pd(SHIFT + 0.5),
        .two_max = _mm256_set1_pd(SHIFT), .absmask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff)),
        .xlim = _mm256_set1_ps(qz->xlim), .bound = _mm256_set1_ps(qz->bound),
    };
    int32_t *const rx = rows[0], *const ry = rows[1], *const rz = rows[2];
    __m256 bad = _mm256_setzero_ps();
    const __m256i px = _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5), py = _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6),
                  pz = _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7);
    uint32_t v = 0;
    for (; v + 8u <= nv; v += 8u) {
        const float *s = src + 3u * v;
        __m256 a = _mm256_loadu_ps(s), b = _mm256_loadu_ps(s + 8), c = _mm256_loadu_ps(s + 16);
        /* x: a lanes 0 3 6, b lanes 1 4 7, c lanes 2 5; y: a 1 4 7, b 2 5, c 0 3 6; z: a 2 5,
         * b 0 3 6, c 1 4 7 */
        __m256 x = _mm256_blend_ps(_mm256_blend_ps(a, b, 0x92), c, 0x24);
        __m256 y = _mm256_blend_ps(_mm256_blend_ps(a, b, 0x24), c, 0x49);
        __m256 z = _mm256_blend_ps(_mm256_blend_ps(a, b, 0x49), c, 0x92);
        _mm256_storeu_si256((__m256i *)(void *)(rx + v), fast8(&k, _mm256_permutevar8x32_ps(x, px), &bad));
        _mm256_storeu_si256((__m256i *)(void *)(ry + v), fast8(&k, _mm256_permutevar8x32_ps(y, py), &bad));
        _mm256_storeu_si256((__m256i *)(void *)(rz + v), fast8(&k, _mm256_permutevar8x32_ps(z, pz), &bad));
    }
    bool ok = _mm256_movemask_ps(bad) == 0;
    return fast_portable(qz, src, v, nv, rows) && ok;
}
#endif

bool codec_quant_fast(const codec_quant *qz, const float *src, uint32_t nv, int32_t *const rows[3], bool portable)
{
#ifdef __AVX2__
    if (!portable) return fast_avx2(qz, src, nv, rows);
#endif
    (void)portable;
    return fast_portable(qz, src, 0, nv, rows);
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

core_status codec_quant_careful(const codec_quant *qz, const float *src, uint32_t nv, int32_t *const rows[3],
                                uint32_t strand, core_err *err)
{
    for (uint32_t v = 0; v < nv; v++)
        for (uint32_t a = 0; a < 3; a++) {
            core_status st = careful_one(qz, src[3u * v + a], strand, v, &rows[a][v], err);
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
