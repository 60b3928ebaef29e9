/* codec: the encoder's rANS frequency tables (normalise, serialise) and symbol setup (the decode
 * core, codec_core.c, parses the tables). */
#include <string.h>

#ifdef __AVX2__
#include <immintrin.h>
#endif

#include "codec_rans.h"

uint32_t codec_rans_normalize(const uint32_t *counts, uint32_t n, uint16_t *freq)
{
    uint64_t total = 0;
    uint32_t used = 0, big = 0;
    for (uint32_t i = 0; i < n; i++) {
        total += counts[i];
        if (counts[i]) used = i + 1u;
        if (counts[i] > counts[big]) big = i;
    }
    if (total == 0) {
        memset(freq, 0, n * sizeof *freq);
        return 0;
    }
    int64_t sum = 0;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t f = (uint32_t)(((uint64_t)counts[i] * CODEC_SCALE) / total);
        if (counts[i] && f == 0) f = 1;
        freq[i] = (uint16_t)f;
        sum += f;
    }
    /* Give the rounding difference to the most frequent symbols (at least 1 each stays). */
    while (sum != (int64_t)CODEC_SCALE) {
        if (sum < (int64_t)CODEC_SCALE) {
            freq[big] = (uint16_t)(freq[big] + (uint16_t)((int64_t)CODEC_SCALE - sum));
            sum = CODEC_SCALE;
        } else {
            uint32_t m = 0;
            for (uint32_t i = 1; i < n; i++)
                if (freq[i] > freq[m]) m = i;
            int64_t take = sum - (int64_t)CODEC_SCALE;
            if (take > (int64_t)freq[m] - 1) take = (int64_t)freq[m] - 1;
            freq[m] = (uint16_t)(freq[m] - take);
            sum -= take;
        }
    }
    return used;
}

void codec_rans_sym_init(codec_rans_sym *s, codec_rans_vsym *vs, uint32_t start, uint32_t freq)
{
    /* x < freq 2^20 and rcp = ceil(2^44 / freq): x rcp / 2^44 - x / freq < x / 2^44 <= 1/freq
     * less the fraction of x / freq, so the floor is exact (freq = 4096 needs no quotient) */
    s->freq = freq;
    s->bias = start;
    s->cmpl_freq = CODEC_SCALE - freq;
    s->rcp = freq < CODEC_SCALE ? ((1ull << 44) + freq - 1u) / freq : 0;
    vs->freq20 = (double)freq * (double)(1u << 20);
    vs->start = start;
    vs->cmpl = (double)(CODEC_SCALE - freq);
    vs->rcp = 1.0 / (double)freq;
}

static uint8_t *put_varint(uint8_t *p, uint32_t v)
{
    while (v >= 0x80u) {
        *p++ = (uint8_t)(v | 0x80u);
        v >>= 7;
    }
    *p++ = (uint8_t)v;
    return p;
}

uint8_t *codec_rans_write_table(uint8_t *p, const uint16_t *freq, uint32_t nsym)
{
    uint32_t used = 0;
    for (uint32_t i = 0; i < nsym; i++) used += freq[i] != 0;
    p = put_varint(p, used);
    uint32_t next = 0;
    for (uint32_t i = 0; i < nsym; i++) {
        if (!freq[i]) continue;
        p = put_varint(p, i - next);
        p = put_varint(p, freq[i]);
        next = i + 1u;
    }
    return p;
}

/* floor(x / freq) for x < freq * 2^20 (codec_rans_sym_init); exact. */
static inline uint32_t quot(uint32_t x, const codec_rans_sym *s)
{
#ifdef __SIZEOF_INT128__
    return (uint32_t)((unsigned __int128)x * s->rcp >> 44);
#else
    return x / s->freq;
#endif
}

/* One symbol into state x without branches: the low word is always stored, the pointer moves
 * when it is emitted. */
static inline __attribute__((always_inline)) uint32_t put(uint32_t x, uint8_t **pp, const codec_rans_sym *s)
{
    const uint32_t emit = (x >> 20) >= s->freq;
    uint8_t *p = *pp - 2;
    codec_put_u16(p, x & 0xffffu);
    *pp = p + 2u * (1u - emit);
    x = emit ? x >> 16 : x;
    return x + s->bias + quot(x, s) * s->cmpl_freq;
}

#if defined(__AVX2__) && defined(__FMA__)
/* For each mask of emitting lanes: the byte shuffle that moves their words (ascending lanes) to
 * the top of 16 bytes (0x80: zero). */
typedef struct compact_lut {
    uint8_t b[256][16];
} compact_lut;

static void compact_init(compact_lut *t)
{
    for (uint32_t m = 0; m < 256; m++) {
        uint32_t c = (uint32_t)__builtin_popcount(m), k = 0;
        memset(t->b[m], 0x80, 16);
        for (uint32_t l = 0; l < 8; l++)
            if (m >> l & 1u) {
                t->b[m][16u - 2u * c + 2u * k] = (uint8_t)(2u * l);
                t->b[m][16u - 2u * c + 2u * k + 1u] = (uint8_t)(2u * l + 1u);
                k++;
            }
    }
}

/* u32 lanes (4) of v as binary64, and back (values below 2^32). */
static inline __m256d u32_to_pd(__m128i v)
{
    return _mm256_add_pd(_mm256_cvtepi32_pd(_mm_xor_si128(v, _mm_set1_epi32(INT32_MIN))), _mm256_set1_pd(2147483648.0));
}

static inline __m128i pd_to_u32(__m256d v)
{
    return _mm_xor_si128(_mm256_cvttpd_epi32(_mm256_sub_pd(v, _mm256_set1_pd(2147483648.0))), _mm_set1_epi32(INT32_MIN));
}

/* One half (4 lanes) of a block on states held in binary64 (every value an integer below 2^33,
 * so exact), with the symbols' freq 2^20, start, SCALE - freq and 1 / freq: emit where
 * x >= freq 2^20 (the word is x - 2^16 h, h = floor(x / 2^16)), x' = h there, else x; then
 * x' + start + floor(x' / freq) (SCALE - freq). The quotient comes straight from x, as
 * floor(x c + 2^-30) with c = 1 / freq, or 2^-16 / freq where the lane emits
 * (floor(h / freq) = floor(x / (2^16 freq))): the quotient is below 2^20 and its fraction is 0
 * or at least 2^-28 from the next integer, and the roundings of c and of the fused sum move it
 * by less than 2^-32, so adding 2^-30 keeps the floor. */
static inline __attribute__((always_inline)) __m256d half_step(__m256d x, const __m256d sym[4], __m128i *word,
                                                                uint32_t *emit)
{
    const __m256d hi = _mm256_round_pd(_mm256_mul_pd(x, _mm256_set1_pd(1.0 / 65536.0)), _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    const __m256d e = _mm256_cmp_pd(x, sym[0], _CMP_GE_OQ);
    *word = _mm256_cvttpd_epi32(_mm256_fnmadd_pd(hi, _mm256_set1_pd(65536.0), x));
    *emit = (uint32_t)_mm256_movemask_pd(e);
    const __m256d c = _mm256_blendv_pd(sym[3], _mm256_mul_pd(sym[3], _mm256_set1_pd(1.0 / 65536.0)), e);
    const __m256d q = _mm256_round_pd(_mm256_fmadd_pd(x, c, _mm256_set1_pd(1.0 / 1073741824.0)),
                                      _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    return _mm256_fmadd_pd(q, sym[2], _mm256_add_pd(_mm256_blendv_pd(x, hi, e), sym[1]));
}

/* The tables of the symbols s[0..4) as four vectors (freq 2^20, start, SCALE - freq, 1 / freq):
 * one load per symbol and a 4 x 4 transposition (on this kind of machine much cheaper than
 * gathers). */
static inline __attribute__((always_inline)) void load_syms(const codec_rans_vsym *vs, const uint16_t *s, __m256d out[4])
{
    const __m256d r0 = _mm256_loadu_pd(&vs[s[0]].freq20), r1 = _mm256_loadu_pd(&vs[s[1]].freq20),
                  r2 = _mm256_loadu_pd(&vs[s[2]].freq20), r3 = _mm256_loadu_pd(&vs[s[3]].freq20);
    const __m256d u0 = _mm256_unpacklo_pd(r0, r1), u1 = _mm256_unpackhi_pd(r0, r1), u2 = _mm256_unpacklo_pd(r2, r3),
                  u3 = _mm256_unpackhi_pd(r2, r3);
    out[0] = _mm256_permute2f128_pd(u0, u2, 0x20);
    out[1] = _mm256_permute2f128_pd(u1, u3, 0x20);
    out[2] = _mm256_permute2f128_pd(u0, u2, 0x31);
    out[3] = _mm256_permute2f128_pd(u1, u3, 0x31);
}

/* Blocks of 8 symbols (lanes 0..7), last first, the 8 states as two vectors of 4 binary64
 * (two independent chains), the emitting lanes' words compacted and stored at once. The same
 * words and states as put(). */
static uint8_t *encode_avx2(const uint16_t *syms, size_t nfull, const codec_rans_vsym *vs, uint8_t *p,
                            uint32_t x[CODEC_LANES])
{
    compact_lut lut; /* 4 KB, built per frame (about a microsecond) */
    compact_init(&lut);
    __m256d x0 = u32_to_pd(_mm_loadu_si128((const __m128i *)(const void *)x));
    __m256d x1 = u32_to_pd(_mm_loadu_si128((const __m128i *)(const void *)(x + 4)));
    for (size_t i = nfull; i >= CODEC_LANES; i -= CODEC_LANES) {
        __m256d s0[4], s1[4];
        load_syms(vs, syms + i - CODEC_LANES, s0);
        load_syms(vs, syms + i - CODEC_LANES / 2u, s1);
        __m128i w0, w1;
        uint32_t e0, e1;
        x0 = half_step(x0, s0, &w0, &e0);
        x1 = half_step(x1, s1, &w1, &e1);
        const uint32_t m = e0 | e1 << 4;
        _mm_storeu_si128((__m128i *)(void *)(p - 16), _mm_shuffle_epi8(_mm_packus_epi32(w0, w1),
                                                                         _mm_loadu_si128((const __m128i *)(const void *)lut.b[m])));
        p -= 2u * (uint32_t)__builtin_popcount(m); /* the bytes below the words are written again later */
    }
    _mm_storeu_si128((__m128i *)(void *)x, pd_to_u32(x0));
    _mm_storeu_si128((__m128i *)(void *)(x + 4), pd_to_u32(x1));
    return p;
}
#endif

uint8_t *codec_rans_encode(const uint16_t *syms, size_t nfull, size_t ntail, uint32_t tail_lanes,
                           const codec_rans_sym *rs, const codec_rans_vsym *vs, uint8_t *end,
                           uint32_t x[CODEC_LANES], bool portable)
{
    uint8_t *p = end;
    for (uint32_t l = 0; l < CODEC_LANES; l++) x[l] = CODEC_RANS_L;
    for (size_t i = ntail; i-- > 0;) {
        const uint32_t l = (uint32_t)(i % tail_lanes);
        x[l] = put(x[l], &p, &rs[syms[nfull + i]]);
    }
#if defined(__AVX2__) && defined(__FMA__)
    if (!portable) return encode_avx2(syms, nfull, vs, p, x);
#endif
    (void)portable;
    (void)vs;
    uint32_t x0 = x[0], x1 = x[1], x2 = x[2], x3 = x[3], x4 = x[4], x5 = x[5], x6 = x[6], x7 = x[7];
    for (size_t i = nfull; i >= CODEC_LANES; i -= CODEC_LANES) {
        const uint16_t *s = syms + i - CODEC_LANES;
        x7 = put(x7, &p, &rs[s[7]]);
        x6 = put(x6, &p, &rs[s[6]]);
        x5 = put(x5, &p, &rs[s[5]]);
        x4 = put(x4, &p, &rs[s[4]]);
        x3 = put(x3, &p, &rs[s[3]]);
        x2 = put(x2, &p, &rs[s[2]]);
        x1 = put(x1, &p, &rs[s[1]]);
        x0 = put(x0, &p, &rs[s[0]]);
    }
    x[0] = x0, x[1] = x1, x[2] = x2, x[3] = x3, x[4] = x4, x[5] = x5, x[6] = x6, x[7] = x7;
    return p;
}
