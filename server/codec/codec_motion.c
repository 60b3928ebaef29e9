/* codec: the rigid motion of a delta frame (serialised, estimated from the roots, and applied
 * to the keyframe: moved roots and moved segments). */
#include <math.h>
#include <string.h>

#ifdef __AVX2__
#include <immintrin.h>
#endif

#include "codec_simd.h"

void codec_motion_identity(codec_motion *m)
{
    memset(m, 0, sizeof *m);
    m->rho[0] = m->rho[4] = m->rho[8] = CODEC_RHO_ONE;
}

void codec_motion_write(uint8_t *p, const codec_motion *m)
{
    memset(p, 0, CODEC_MOTION_BYTES);
    for (int k = 0; k < 9; k++) codec_put_u16(p + 2 * k, (uint32_t)m->rho[k] & 0xffffu);
    for (int k = 0; k < 3; k++) codec_put_u32(p + 20 + 4 * k, (uint32_t)m->t[k]);
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

/* The rotation part of the moved root (before the translation), exact. */
static int64_t rotated(const codec_motion *m, const int32_t k[3], uint32_t a)
{
    const int32_t *r = m->rho + 3u * a;
    return ((int64_t)r[0] * k[0] + (int64_t)r[1] * k[1] + (int64_t)r[2] * k[2] + 8192) >> 14;
}

void codec_motion_estimate(const int32_t *key, const int32_t *cur, uint32_t nstrands, uint32_t step, codec_motion *m)
{
    codec_motion_identity(m);
    const uint32_t n = (nstrands + step - 1u) / step; /* roots used */
    if (n >= 3) {
        double ca[3] = { 0, 0, 0 }, cb[3] = { 0, 0, 0 };
        for (uint32_t j = 0; j < nstrands; j += step)
            for (int a = 0; a < 3; a++) {
                ca[a] += key[3u * j + (uint32_t)a];
                cb[a] += cur[3u * j + (uint32_t)a];
            }
        for (int a = 0; a < 3; a++) {
            ca[a] /= n;
            cb[a] /= n;
        }
        double h[9] = { 0 }; /* sum (b - cb)(a - ca)^T: R = polar factor */
        for (uint32_t j = 0; j < nstrands; j += step) {
            double da[3], db[3];
            for (int a = 0; a < 3; a++) {
                da[a] = key[3u * j + (uint32_t)a] - ca[a];
                db[a] = cur[3u * j + (uint32_t)a] - cb[a];
            }
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 3; c++) h[3 * r + c] += db[r] * da[c];
        }
        double scale = 0, rot[9];
        for (int k = 0; k < 9; k++) scale = fmax(scale, fabs(h[k]));
        if (scale > 0) {
            for (int k = 0; k < 9; k++) h[k] /= scale;
            if (polar(h, rot))
                for (int k = 0; k < 9; k++)
                    m->rho[k] = (int32_t)fmax(-CODEC_RHO_ONE, fmin(CODEC_RHO_ONE, nearbyint(rot[k] * CODEC_RHO_ONE)));
        }
    }
    /* the translation after the rotation is quantised: the mean offset of the rotated roots */
    for (uint32_t a = 0; a < 3; a++) {
        double sum = 0;
        for (uint32_t j = 0; j < nstrands; j += step) sum += (double)cur[3u * j + a] - (double)rotated(m, key + 3u * j, a);
        double t = n ? nearbyint(sum / n) : 0.0;
        m->t[a] = (int32_t)fmax(-CODEC_T_MAX, fmin(CODEC_T_MAX, t));
    }
}

/* Where the packed segment words of vertex v >= 1 begin in a reference: [lane] d_x | d_y << 16,
 * then [lane] d_z | 1 << 16. */
static inline size_t kref_seg(uint32_t v)
{
    return CODEC_GSTRIDE + 2u * CODEC_GROUP * (size_t)(v - 1u);
}

static void kref_portable(const int32_t *K, uint32_t nv, int32_t *kref)
{
    memcpy(kref, K, CODEC_GSTRIDE * sizeof *kref);
    for (uint32_t v = 1; v < nv; v++) {
        int32_t *w = kref + kref_seg(v);
        for (uint32_t l = 0; l < CODEC_GROUP; l++) {
            uint32_t d[3];
            for (uint32_t a = 0; a < 3; a++)
                d[a] = (uint32_t)codec_clamp15(K[CODEC_GAT(v, a, l)] - K[CODEC_GAT(v - 1u, a, l)]) & 0xffffu;
            w[l] = (int32_t)(d[0] | d[1] << 16);
            w[CODEC_GROUP + l] = (int32_t)(d[2] | 1u << 16);
        }
    }
}

/* X[0] = the moved roots, X[v] = X[v-1] + S[v]: the segments of X are the moved segments (no
 * sum overflows: |S| < 2^17 and nv <= 4096). */
static void moved_roots(const codec_motion *m, const int32_t *kref, int32_t *X)
{
    for (uint32_t l = 0; l < CODEC_GROUP; l++) {
        const int32_t r[3] = { kref[CODEC_GAT(0, 0, l)], kref[CODEC_GAT(0, 1, l)], kref[CODEC_GAT(0, 2, l)] };
        for (uint32_t a = 0; a < 3; a++) X[CODEC_GAT(0, a, l)] = codec_moved_root(m, r, a);
    }
}

static void group_portable(const codec_motion *m, const int32_t *kref, int32_t *X, uint32_t nv)
{
    moved_roots(m, kref, X);
    for (uint32_t v = 1; v < nv; v++) {
        const int32_t *w = kref + kref_seg(v);
        for (uint32_t l = 0; l < CODEC_GROUP; l++) {
            const int32_t d[3] = { (int16_t)(w[l] & 0xffff), (int16_t)((uint32_t)w[l] >> 16),
                                   (int16_t)(w[CODEC_GROUP + l] & 0xffff) };
            for (uint32_t a = 0; a < 3; a++) X[CODEC_GAT(v, a, l)] = X[CODEC_GAT(v - 1u, a, l)] + codec_moved_seg(m, d, a);
        }
    }
}

#ifdef __AVX2__
static void kref_avx2(const int32_t *K, uint32_t nv, int32_t *kref)
{
    memcpy(kref, K, CODEC_GSTRIDE * sizeof *kref);
    const __m256i lo = _mm256_set1_epi32(-CODEC_SEG_MAX), hi = _mm256_set1_epi32(CODEC_SEG_MAX),
                  one_hi = _mm256_set1_epi32(1 << 16);
    __m256i k0[3];
    for (uint32_t a = 0; a < 3; a++) k0[a] = codec_ldg(K, 0, a);
    for (uint32_t v = 1; v < nv; v++) {
        __m256i d[3];
        for (uint32_t a = 0; a < 3; a++) {
            __m256i k1 = codec_ldg(K, v, a);
            d[a] = _mm256_max_epi32(_mm256_min_epi32(_mm256_sub_epi32(k1, k0[a]), hi), lo);
            k0[a] = k1;
        }
        int32_t *w = kref + kref_seg(v);
        _mm256_storeu_si256((__m256i *)(void *)w, _mm256_blend_epi16(d[0], _mm256_slli_epi32(d[1], 16), 0xaa));
        _mm256_storeu_si256((__m256i *)(void *)(w + CODEC_GROUP), _mm256_blend_epi16(d[2], one_hi, 0xaa));
    }
}

/* The same, 8 lanes at a time: per axis two 16-bit multiply-adds, (d_x, d_y) . (rho_0, rho_1)
 * and (d_z, 1) . (rho_2, 8192) (|rho| <= 2^14 and |d| < 2^15 fit in 16 bits, no sum overflows). */
static void group_avx2(const codec_motion *m, const int32_t *kref, int32_t *X, uint32_t nv, bool more)
{
    moved_roots(m, kref, X);
    __m256i rxy[3], rz[3], x0[3];
    for (uint32_t a = 0; a < 3; a++) {
        rxy[a] = _mm256_set1_epi32((int32_t)(((uint32_t)m->rho[3 * a] & 0xffffu) | (uint32_t)m->rho[3 * a + 1] << 16));
        rz[a] = _mm256_set1_epi32((int32_t)(((uint32_t)m->rho[3 * a + 2] & 0xffffu) | 8192u << 16));
        x0[a] = codec_ldg(X, 0, a);
    }
    for (uint32_t v = 1; v < nv; v++) {
        const int32_t *w = kref + kref_seg(v);
        if (more && (v & 1u)) /* the next group's reference, a cache line per two vertices */
            __builtin_prefetch(w + CODEC_KREF_SIZE(nv));
        const __m256i dxy = _mm256_loadu_si256((const __m256i *)(const void *)w);
        const __m256i dz1 = _mm256_loadu_si256((const __m256i *)(const void *)(w + CODEC_GROUP));
        for (uint32_t a = 0; a < 3; a++) {
            __m256i s = _mm256_add_epi32(_mm256_madd_epi16(dxy, rxy[a]), _mm256_madd_epi16(dz1, rz[a]));
            x0[a] = _mm256_add_epi32(x0[a], _mm256_srai_epi32(s, 14));
            codec_stg(X, v, a, x0[a]);
        }
    }
}
#endif

void codec_kref_group(const int32_t *K, uint32_t nv, int32_t *kref, bool portable)
{
#ifdef __AVX2__
    if (!portable) {
        kref_avx2(K, nv, kref);
        return;
    }
#endif
    (void)portable;
    kref_portable(K, nv, kref);
}

void codec_motion_group(const codec_motion *m, const int32_t *kref, int32_t *X, uint32_t nv, bool more, bool portable)
{
#ifdef __AVX2__
    if (!portable) {
        group_avx2(m, kref, X, nv, more);
        return;
    }
#endif
    (void)portable;
    (void)more;
    group_portable(m, kref, X, nv);
}
