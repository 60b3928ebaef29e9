/* codec: the rigid motion of a delta frame (estimated from the roots, applied to the keyframe
 * lattice to give the motion-compensated temporal reference). */
#include <math.h>
#include <string.h>

#ifdef __AVX2__
#include <immintrin.h>
#endif

#include "codec_enc.h"

void codec_motion_identity(float m[12])
{
    memset(m, 0, 12 * sizeof *m);
    m[0] = m[4] = m[8] = 1.0f;
}

bool codec_motion_valid(const float m[12])
{
    for (int k = 0; k < 9; k++)
        if (!(fabsf(m[k]) <= 2.0f)) return false;
    for (int k = 9; k < 12; k++)
        if (!(fabsf(m[k]) <= (float)(4 * CODEC_MAX_QUANT))) return false;
    return true;
}

static double det3(const double a[9])
{
    return a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) + a[2] * (a[3] * a[7] - a[4] * a[6]);
}

/* The orthogonal polar factor of a (Newton: X <- (X + X^-T) / 2); false if singular. */
static bool polar(const double a[9], double q[9])
{
    double x[9];
    memcpy(x, a, sizeof x);
    for (int it = 0; it < 30; it++) {
        double d = det3(x);
        if (!(fabs(d) > 1e-300) || !isfinite(d)) return false;
        /* inverse transpose = cofactor matrix / det */
        double c[9] = {
            x[4] * x[8] - x[5] * x[7], x[5] * x[6] - x[3] * x[8], x[3] * x[7] - x[4] * x[6],
            x[2] * x[7] - x[1] * x[8], x[0] * x[8] - x[2] * x[6], x[1] * x[6] - x[0] * x[7],
            x[1] * x[5] - x[2] * x[4], x[2] * x[3] - x[0] * x[5], x[0] * x[4] - x[1] * x[3],
        };
        double delta = 0;
        for (int k = 0; k < 9; k++) {
            double n = 0.5 * (x[k] + c[k] / d);
            delta = fmax(delta, fabs(n - x[k]));
            x[k] = n;
        }
        if (delta < 1e-12) break;
    }
    memcpy(q, x, sizeof x);
    return det3(q) > 0.5;
}

void codec_motion_estimate(const int32_t *key, const int32_t *cur, uint32_t nstrands, float m[12])
{
    codec_motion_identity(m);
    if (nstrands < 3) return;
    double ca[3] = { 0, 0, 0 }, cb[3] = { 0, 0, 0 };
    for (uint32_t j = 0; j < nstrands; j++)
        for (int a = 0; a < 3; a++) {
            ca[a] += key[3u * j + (uint32_t)a];
            cb[a] += cur[3u * j + (uint32_t)a];
        }
    for (int a = 0; a < 3; a++) {
        ca[a] /= nstrands;
        cb[a] /= nstrands;
    }
    double h[9] = { 0 }; /* sum (b - cb)(a - ca)^T: R = polar factor */
    for (uint32_t j = 0; j < nstrands; j++) {
        double da[3], db[3];
        for (int a = 0; a < 3; a++) {
            da[a] = key[3u * j + (uint32_t)a] - ca[a];
            db[a] = cur[3u * j + (uint32_t)a] - cb[a];
        }
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++) h[3 * r + c] += db[r] * da[c];
    }
    double scale = 0;
    for (int k = 0; k < 9; k++) scale = fmax(scale, fabs(h[k]));
    if (!(scale > 0)) return;
    for (int k = 0; k < 9; k++) h[k] /= scale;
    double rot[9];
    if (!polar(h, rot)) return;
    float f[12];
    for (int k = 0; k < 9; k++) f[k] = (float)rot[k];
    for (int r = 0; r < 3; r++)
        f[9 + r] = (float)(cb[r] - ((double)f[3 * r] * ca[0] + (double)f[3 * r + 1] * ca[1] + (double)f[3 * r + 2] * ca[2]));
    if (codec_motion_valid(f)) memcpy(m, f, sizeof f);
}

static void apply_portable(const float m[12], const int32_t *restrict k, int32_t *restrict out, size_t from,
                           size_t nverts)
{
    /* trunc(s + t + 2^30 + 1/2) - 2^30 = round half up of s + t; the sum stays in (0, 2^31)
     * because |r| <= 2, |k| < 2^26 and |t| <= 2^28 */
    const int32_t lim = CODEC_MAX_QUANT - 1, off = 1 << 30;
    const double r0 = m[0], r1 = m[1], r2 = m[2], r3 = m[3], r4 = m[4], r5 = m[5], r6 = m[6], r7 = m[7], r8 = m[8];
    const double c0 = (double)m[9] + 1073741824.5, c1 = (double)m[10] + 1073741824.5, c2 = (double)m[11] + 1073741824.5;
    for (size_t i = from; i < nverts; i++) {
        double x = k[3 * i], y = k[3 * i + 1], z = k[3 * i + 2];
        int32_t w[3] = { (int32_t)(r0 * x + r1 * y + r2 * z + c0) - off, (int32_t)(r3 * x + r4 * y + r5 * z + c1) - off,
                         (int32_t)(r6 * x + r7 * y + r8 * z + c2) - off };
        for (int a = 0; a < 3; a++) out[3 * i + (size_t)a] = w[a] < -lim ? -lim : w[a] > lim ? lim : w[a];
    }
}

#ifdef __AVX2__
/* 8 vertices at a time: de-interleaved into x, y, z (blends, lane permutations), two halves in
 * binary64 (the same operations in the same order), interleaved back. */
static size_t apply_avx2(const float m[12], const int32_t *restrict k, int32_t *restrict out, size_t nverts)
{
    const __m128i lim = _mm_set1_epi32(CODEC_MAX_QUANT - 1), nlim = _mm_set1_epi32(-(CODEC_MAX_QUANT - 1)),
                  off = _mm_set1_epi32(1 << 30);
    const __m256i px = _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5), py = _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6),
                  pz = _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7), qy = _mm256_setr_epi32(5, 0, 3, 6, 1, 4, 7, 2);
    __m256d r[9], c[3];
    for (int i = 0; i < 9; i++) r[i] = _mm256_set1_pd((double)m[i]);
    for (int a = 0; a < 3; a++) c[a] = _mm256_set1_pd((double)m[9 + a] + 1073741824.5);
    size_t i = 0;
    for (; i + 8u <= nverts; i += 8u) {
        const __m256i *src = (const __m256i *)(const void *)(k + 3u * i);
        __m256i a = _mm256_loadu_si256(src), b = _mm256_loadu_si256(src + 1), d = _mm256_loadu_si256(src + 2);
        __m256i v[3] = {
            _mm256_permutevar8x32_epi32(_mm256_blend_epi32(_mm256_blend_epi32(a, b, 0x92), d, 0x24), px),
            _mm256_permutevar8x32_epi32(_mm256_blend_epi32(_mm256_blend_epi32(a, b, 0x24), d, 0x49), py),
            _mm256_permutevar8x32_epi32(_mm256_blend_epi32(_mm256_blend_epi32(a, b, 0x49), d, 0x92), pz),
        };
        __m128i w[3][2];
        for (int h = 0; h < 2; h++) {
            __m256d x = _mm256_cvtepi32_pd(h ? _mm256_extracti128_si256(v[0], 1) : _mm256_castsi256_si128(v[0]));
            __m256d y = _mm256_cvtepi32_pd(h ? _mm256_extracti128_si256(v[1], 1) : _mm256_castsi256_si128(v[1]));
            __m256d z = _mm256_cvtepi32_pd(h ? _mm256_extracti128_si256(v[2], 1) : _mm256_castsi256_si128(v[2]));
            for (int ax = 0; ax < 3; ax++) {
                __m256d s = _mm256_add_pd(_mm256_mul_pd(r[3 * ax], x), _mm256_mul_pd(r[3 * ax + 1], y));
                s = _mm256_add_pd(_mm256_add_pd(s, _mm256_mul_pd(r[3 * ax + 2], z)), c[ax]);
                w[ax][h] = _mm_max_epi32(_mm_min_epi32(_mm_sub_epi32(_mm256_cvttpd_epi32(s), off), lim), nlim);
            }
        }
        /* back to x y z order: the inverse lane permutations, then the blends */
        __m256i X = _mm256_permutevar8x32_epi32(_mm256_set_m128i(w[0][1], w[0][0]), px);
        __m256i Y = _mm256_permutevar8x32_epi32(_mm256_set_m128i(w[1][1], w[1][0]), qy);
        __m256i Z = _mm256_permutevar8x32_epi32(_mm256_set_m128i(w[2][1], w[2][0]), pz);
        __m256i *dst = (__m256i *)(void *)(out + 3u * i);
        _mm256_storeu_si256(dst, _mm256_blend_epi32(_mm256_blend_epi32(X, Y, 0x92), Z, 0x24));
        _mm256_storeu_si256(dst + 1, _mm256_blend_epi32(_mm256_blend_epi32(Z, X, 0x92), Y, 0x24));
        _mm256_storeu_si256(dst + 2, _mm256_blend_epi32(_mm256_blend_epi32(Y, X, 0x24), Z, 0x92));
    }
    return i;
}
#endif

void codec_motion_apply(const float m[12], const int32_t *restrict k, int32_t *restrict out, size_t nverts)
{
    size_t done = 0;
#ifdef __AVX2__
    done = apply_avx2(m, k, out, nverts);
#endif
    apply_portable(m, k, out, done, nverts);
}

static void apply_group_portable(const float m[12], const int32_t *k, int32_t *out, uint32_t nv)
{
    const int32_t lim = CODEC_MAX_QUANT - 1, off = 1 << 30;
    const double c[3] = { (double)m[9] + 1073741824.5, (double)m[10] + 1073741824.5, (double)m[11] + 1073741824.5 };
    for (uint32_t v = 0; v < nv; v++)
        for (uint32_t l = 0; l < CODEC_GROUP; l++) {
            double x = k[CODEC_GAT(v, 0, l)], y = k[CODEC_GAT(v, 1, l)], z = k[CODEC_GAT(v, 2, l)];
            for (uint32_t a = 0; a < 3; a++) {
                int32_t w = (int32_t)((double)m[3 * a] * x + (double)m[3 * a + 1] * y + (double)m[3 * a + 2] * z + c[a]) - off;
                out[CODEC_GAT(v, a, l)] = w < -lim ? -lim : w > lim ? lim : w;
            }
        }
}

#ifdef __AVX2__
/* Per vertex two halves of 4 strands in binary64, the same operations in the same order. */
static void apply_group_avx2(const float m[12], const int32_t *k, int32_t *out, uint32_t nv)
{
    const __m128i lim = _mm_set1_epi32(CODEC_MAX_QUANT - 1), nlim = _mm_set1_epi32(-(CODEC_MAX_QUANT - 1)),
                  off = _mm_set1_epi32(1 << 30);
    __m256d r[9], c[3];
    for (int i = 0; i < 9; i++) r[i] = _mm256_set1_pd((double)m[i]);
    for (int a = 0; a < 3; a++) c[a] = _mm256_set1_pd((double)m[9 + a] + 1073741824.5);
    for (size_t i = 0; i < (size_t)nv * 2u; i++) {
        /* vertex i / 2, strands 4 (i & 1) .. 4 (i & 1) + 3 */
        const int32_t *kv = k + (i >> 1) * CODEC_GSTRIDE + (i & 1u) * 4u;
        int32_t *ov = out + (i >> 1) * CODEC_GSTRIDE + (i & 1u) * 4u;
        __m256d x = _mm256_cvtepi32_pd(_mm_loadu_si128((const __m128i *)(const void *)kv));
        __m256d y = _mm256_cvtepi32_pd(_mm_loadu_si128((const __m128i *)(const void *)(kv + CODEC_GROUP)));
        __m256d z = _mm256_cvtepi32_pd(_mm_loadu_si128((const __m128i *)(const void *)(kv + 2u * CODEC_GROUP)));
        for (int a = 0; a < 3; a++) {
            __m256d s = _mm256_add_pd(_mm256_mul_pd(r[3 * a], x), _mm256_mul_pd(r[3 * a + 1], y));
            s = _mm256_add_pd(_mm256_add_pd(s, _mm256_mul_pd(r[3 * a + 2], z)), c[a]);
            __m128i w = _mm_sub_epi32(_mm256_cvttpd_epi32(s), off);
            w = _mm_max_epi32(_mm_min_epi32(w, lim), nlim);
            _mm_storeu_si128((__m128i *)(void *)(ov + (size_t)a * CODEC_GROUP), w);
        }
    }
}
#endif

void codec_motion_apply_group(const float m[12], const int32_t *k, int32_t *out, uint32_t nv, bool portable)
{
#ifdef __AVX2__
    if (!portable) {
        apply_group_avx2(m, k, out, nv);
        return;
    }
#endif
    (void)portable;
    apply_group_portable(m, k, out, nv);
}
