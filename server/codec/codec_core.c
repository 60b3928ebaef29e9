/* codec core: the strand frame decoder (codec_core.h). A frame is decoded a group of 8 strands at
 * a time: the group's symbols (8 rANS lanes, vertex by vertex across the lanes) become residuals
 * (k->r, vertex-major: a delta's axis-major and lane-minor, a keyframe's lane-major with the
 * x, y, z of a lane together), then the group's strands are rebuilt: a delta frame's 8 strands at
 * once (2 x 4 lanes per axis), a keyframe's one after another (each predicts from the one before,
 * x, y, z in the lanes of one vector). The vectors are 4 x int32, in one of three paths chosen by
 * the compiler's target: WebAssembly SIMD (__wasm_simd128__), AVX2 (__AVX2__; float conversion in
 * 256 bits, the rest SSE4.1), or portable C (otherwise, or with CODEC_CORE_PORTABLE). Every path
 * gives the same bits; integer arithmetic wraps modulo 2^32 as the format's predictions do. */
#include "codec_core.h"

#include "codec_crc_table.h"
#include "codec_internal.h"

#if defined(__wasm_simd128__) && !defined(CODEC_CORE_PORTABLE)
#define CORE_WASM 1
#include <wasm_simd128.h>
#elif defined(__AVX2__) && !defined(CODEC_CORE_PORTABLE)
#define CORE_AVX2 1
#include <immintrin.h>
#endif

#define T_MODE CODEC_T_MODE
#define T_ROOT CODEC_T_ROOT
#define T_FIRST CODEC_T_FIRST
#define T_BODY CODEC_T_BODY
#define NTABLES CODEC_NTABLES
#define NSYM CODEC_NSYM
#define SCALE CODEC_SCALE
#define LANES CODEC_LANES
#define HEADER CODEC_HEADER_SIZE
#define MOTION_BYTES CODEC_MOTION_BYTES
#define T_IDLE 9           /* the lanes past the last strand: keep their state, no raw bits */
#define INFO_SLOW 512      /* an escaped axis */
#define INFO_NEXT 0xf000   /* the next vertex's table << 12 */
#define INFO_UNUSED 0x9fff /* every slot of an unused table: INFO_SLOW, next table T_IDLE */
#define QMAX (CODEC_MAX_QUANT - 1) /* |lattice coordinate| <= 2^26 - 1 */

_Static_assert(__builtin_offsetof(codec_core, key) == 104, "codec.js reads key at 104");
_Static_assert(__builtin_offsetof(codec_core, error) == 208, "codec.js reads error at 208");
_Static_assert(__builtin_offsetof(codec_core, key_valid) == 240, "codec.js reads key_valid at 240");
_Static_assert(__builtin_offsetof(codec_core, key_slot) == 244, "codec.js reads key_slot at 244");
_Static_assert(__builtin_offsetof(codec_core_info, sim_step) == 64 && __builtin_offsetof(codec_core_info, head_pos) == 72 &&
                   __builtin_offsetof(codec_core_info, head_rot) == 84,
               "codec.js reads the step and head at 64, 72, 84");
_Static_assert(sizeof(codec_core_info) == 104 && sizeof(codec_core_error) == 32, "fixed layouts");

/* ---- 4 x int32 vectors ---- */
#if CORE_WASM
typedef v128_t vi;
typedef v128_t vstep; /* the quantisation step, as the conversion wants it */
static inline vi v_load(const void *p) { return wasm_v128_load(p); }
static inline void v_store(void *p, vi x) { wasm_v128_store(p, x); }
static inline vi v_splat(int32_t a) { return wasm_i32x4_splat(a); }
static inline vi v_add(vi a, vi b) { return wasm_i32x4_add(a, b); }
static inline vi v_sub(vi a, vi b) { return wasm_i32x4_sub(a, b); }
static inline vi v_mul(vi a, vi b) { return wasm_i32x4_mul(a, b); }
static inline vi v_and(vi a, vi b) { return wasm_v128_and(a, b); }
static inline vi v_or(vi a, vi b) { return wasm_v128_or(a, b); }
static inline vi v_xor(vi a, vi b) { return wasm_v128_xor(a, b); }
static inline vi v_not(vi a) { return wasm_v128_not(a); }
static inline vi v_neg(vi a) { return wasm_i32x4_neg(a); }
static inline vi v_sra(vi a, int n) { return wasm_i32x4_shr(a, (uint32_t)n); }
static inline vi v_srl(vi a, int n) { return wasm_u32x4_shr(a, (uint32_t)n); }
static inline vi v_abs(vi a) { return wasm_i32x4_abs(a); }
static inline vi v_maxu(vi a, vi b) { return wasm_u32x4_max(a, b); }
static inline vi v_eq(vi a, vi b) { return wasm_i32x4_eq(a, b); }
static inline vi v_lt(vi a, vi b) { return wasm_i32x4_lt(a, b); }
/* m ? a : b, bit by bit */
static inline vi v_sel(vi a, vi b, vi m) { return wasm_v128_bitselect(a, b, m); }
/* the sign bits of the lanes (bit l: lane l) */
static inline int v_signs(vi a) { return wasm_i32x4_bitmask(a); }
/* bit l: lane l of a above that of b, unsigned */
static inline int v_gtu(vi a, vi b) { return wasm_i32x4_bitmask(wasm_u32x4_gt(a, b)); }
/* per lane: the products of its two int16 halves summed */
static inline vi v_dot16(vi a, vi b) { return wasm_i32x4_dot_i16x8(a, b); }
static inline vstep v_step(double s) { return wasm_f64x2_splat(s); }

/* float32(q * step) of the 4 lanes of q, as bits */
static inline vi v_tofloat(vi q, vstep st)
{
    v128_t lo = wasm_f32x4_demote_f64x2_zero(wasm_f64x2_mul(wasm_f64x2_convert_low_i32x4(q), st));
    v128_t hi = wasm_f32x4_demote_f64x2_zero(
        wasm_f64x2_mul(wasm_f64x2_convert_low_i32x4(wasm_i32x4_shuffle(q, q, 2, 3, 2, 3)), st));
    return wasm_i32x4_shuffle(lo, hi, 0, 1, 4, 5);
}

/* lanes 0..2 of v to p (12 bytes) */
static inline void v_store3(void *p, vi v)
{
    wasm_v128_store64_lane(p, v, 0);
    wasm_v128_store32_lane((char *)p + 8, v, 2);
}

/* d = clamp15(lanes 0..2 of s): (d_0, d_1) as int16 to pd[0..2), (d_2, 1) to pd[16..18) */
static inline void v_store_seg(int16_t *pd, vi s)
{
    v128_t d = wasm_i32x4_shuffle(wasm_i32x4_max(s, wasm_i32x4_splat(-32767)), wasm_i32x4_splat(1), 0, 1, 2, 4);
    v128_t h = wasm_i16x8_narrow_i32x4(d, d);
    wasm_v128_store32_lane(pd, h, 0);
    wasm_v128_store32_lane(pd + 16, h, 1);
}

/* lane l of (x, y, z) as (x_l, y_l, z_l, any) */
static inline void v_transpose(vi x, vi y, vi z, vi out[4])
{
    v128_t t0 = wasm_i32x4_shuffle(x, y, 0, 4, 1, 5), t1 = wasm_i32x4_shuffle(x, y, 2, 6, 3, 7);
    out[0] = wasm_i32x4_shuffle(t0, z, 0, 1, 4, 4);
    out[1] = wasm_i32x4_shuffle(t0, z, 2, 3, 5, 5);
    out[2] = wasm_i32x4_shuffle(t1, z, 0, 1, 6, 6);
    out[3] = wasm_i32x4_shuffle(t1, z, 2, 3, 7, 7);
}
#elif CORE_AVX2
typedef __m128i vi;
typedef __m256d vstep;
static inline vi v_load(const void *p) { return _mm_loadu_si128((const __m128i *)p); }
static inline void v_store(void *p, vi x) { _mm_storeu_si128((__m128i *)p, x); }
static inline vi v_splat(int32_t a) { return _mm_set1_epi32(a); }
static inline vi v_add(vi a, vi b) { return _mm_add_epi32(a, b); }
static inline vi v_sub(vi a, vi b) { return _mm_sub_epi32(a, b); }
static inline vi v_mul(vi a, vi b) { return _mm_mullo_epi32(a, b); }
static inline vi v_and(vi a, vi b) { return _mm_and_si128(a, b); }
static inline vi v_or(vi a, vi b) { return _mm_or_si128(a, b); }
static inline vi v_xor(vi a, vi b) { return _mm_xor_si128(a, b); }
static inline vi v_not(vi a) { return _mm_xor_si128(a, _mm_set1_epi32(-1)); }
static inline vi v_neg(vi a) { return _mm_sub_epi32(_mm_setzero_si128(), a); }
static inline vi v_sra(vi a, int n) { return _mm_sra_epi32(a, _mm_cvtsi32_si128(n)); }
static inline vi v_srl(vi a, int n) { return _mm_srl_epi32(a, _mm_cvtsi32_si128(n)); }
static inline vi v_abs(vi a) { return _mm_abs_epi32(a); }
static inline vi v_maxu(vi a, vi b) { return _mm_max_epu32(a, b); }
static inline vi v_eq(vi a, vi b) { return _mm_cmpeq_epi32(a, b); }
static inline vi v_lt(vi a, vi b) { return _mm_cmplt_epi32(a, b); }
static inline vi v_sel(vi a, vi b, vi m) { return _mm_or_si128(_mm_and_si128(m, a), _mm_andnot_si128(m, b)); }
static inline int v_signs(vi a) { return _mm_movemask_ps(_mm_castsi128_ps(a)); }
static inline int v_gtu(vi a, vi b)
{
    const __m128i bias = _mm_set1_epi32(INT32_MIN);
    return v_signs(_mm_cmpgt_epi32(_mm_xor_si128(a, bias), _mm_xor_si128(b, bias)));
}
static inline vi v_dot16(vi a, vi b) { return _mm_madd_epi16(a, b); }
static inline vstep v_step(double s) { return _mm256_set1_pd(s); }

static inline vi v_tofloat(vi q, vstep st)
{
    return _mm_castps_si128(_mm256_cvtpd_ps(_mm256_mul_pd(_mm256_cvtepi32_pd(q), st)));
}

static inline void v_store3(void *p, vi v)
{
    _mm_storel_epi64((__m128i *)p, v);
    int32_t z = _mm_extract_epi32(v, 2);
    __builtin_memcpy((char *)p + 8, &z, 4);
}

static inline void v_store_seg(int16_t *pd, vi s)
{
    __m128i d = _mm_insert_epi32(_mm_max_epi32(s, _mm_set1_epi32(-32767)), 1, 3);
    __m128i h = _mm_packs_epi32(d, d);
    int32_t lo = _mm_cvtsi128_si32(h), hi = _mm_extract_epi32(h, 1);
    __builtin_memcpy(pd, &lo, 4);
    __builtin_memcpy(pd + 16, &hi, 4);
}

static inline void v_transpose(vi x, vi y, vi z, vi out[4])
{
    __m128i t0 = _mm_unpacklo_epi32(x, y), t1 = _mm_unpackhi_epi32(x, y);
    out[0] = _mm_unpacklo_epi64(t0, z);
    out[1] = _mm_unpacklo_epi64(_mm_srli_si128(t0, 8), _mm_srli_si128(z, 4));
    out[2] = _mm_unpacklo_epi64(t1, _mm_srli_si128(z, 8));
    out[3] = _mm_unpacklo_epi64(_mm_srli_si128(t1, 8), _mm_srli_si128(z, 12));
}
#else
typedef struct vi {
    int32_t l[4];
} vi;
typedef double vstep;
#define V_MAP(expr)                                                                                                    \
    vi r_;                                                                                                             \
    for (int i = 0; i < 4; i++) r_.l[i] = (int32_t)(expr);                                                             \
    return r_
static inline vi v_load(const void *p)
{
    vi r;
    __builtin_memcpy(r.l, p, 16);
    return r;
}
static inline void v_store(void *p, vi x) { __builtin_memcpy(p, x.l, 16); }
static inline vi v_splat(int32_t a) { V_MAP(a); }
static inline vi v_make(int32_t a, int32_t b, int32_t c, int32_t d) { return (vi){ { a, b, c, d } }; }
static inline vi v_add(vi a, vi b) { V_MAP((uint32_t)a.l[i] + (uint32_t)b.l[i]); }
static inline vi v_sub(vi a, vi b) { V_MAP((uint32_t)a.l[i] - (uint32_t)b.l[i]); }
static inline vi v_mul(vi a, vi b) { V_MAP((uint32_t)a.l[i] * (uint32_t)b.l[i]); }
static inline vi v_and(vi a, vi b) { V_MAP(a.l[i] & b.l[i]); }
static inline vi v_or(vi a, vi b) { V_MAP(a.l[i] | b.l[i]); }
static inline vi v_xor(vi a, vi b) { V_MAP(a.l[i] ^ b.l[i]); }
static inline vi v_not(vi a) { V_MAP(~a.l[i]); }
static inline vi v_neg(vi a) { V_MAP(0u - (uint32_t)a.l[i]); }
static inline vi v_sra(vi a, int n) { V_MAP(a.l[i] >> n); }
static inline vi v_srl(vi a, int n) { V_MAP((uint32_t)a.l[i] >> n); }
static inline vi v_abs(vi a) { V_MAP(a.l[i] < 0 ? 0u - (uint32_t)a.l[i] : (uint32_t)a.l[i]); }
static inline vi v_maxu(vi a, vi b) { V_MAP((uint32_t)a.l[i] > (uint32_t)b.l[i] ? a.l[i] : b.l[i]); }
static inline vi v_eq(vi a, vi b) { V_MAP(a.l[i] == b.l[i] ? -1 : 0); }
static inline vi v_lt(vi a, vi b) { V_MAP(a.l[i] < b.l[i] ? -1 : 0); }
static inline vi v_sel(vi a, vi b, vi m) { V_MAP((a.l[i] & m.l[i]) | (b.l[i] & ~m.l[i])); }
static inline vi v_dot16(vi a, vi b)
{
    V_MAP((uint32_t)((int32_t)(int16_t)a.l[i] * (int16_t)b.l[i]) +
          (uint32_t)((int32_t)(int16_t)(a.l[i] >> 16) * (int16_t)(b.l[i] >> 16)));
}
static inline vstep v_step(double s) { return s; }
static inline int v_signs(vi a)
{
    int m = 0;
    for (int i = 0; i < 4; i++) m |= (a.l[i] < 0) << i;
    return m;
}
static inline int v_gtu(vi a, vi b)
{
    int m = 0;
    for (int i = 0; i < 4; i++) m |= ((uint32_t)a.l[i] > (uint32_t)b.l[i]) << i;
    return m;
}
static inline vi v_tofloat(vi q, vstep st)
{
    vi r;
    for (int i = 0; i < 4; i++) {
        union {
            float f;
            int32_t i;
        } u = { .f = (float)((double)q.l[i] * st) };
        r.l[i] = u.i;
    }
    return r;
}
static inline void v_store3(void *p, vi v) { __builtin_memcpy(p, v.l, 12); }
static inline void v_store_seg(int16_t *pd, vi s)
{
    int16_t d[3];
    for (int i = 0; i < 3; i++) d[i] = (int16_t)(s.l[i] < -32767 ? -32767 : s.l[i] > 32767 ? 32767 : s.l[i]);
    pd[0] = d[0];
    pd[1] = d[1];
    pd[16] = d[2];
    pd[17] = 1;
}
static inline void v_transpose(vi x, vi y, vi z, vi out[4])
{
    for (int l = 0; l < 4; l++) out[l] = v_make(x.l[l], y.l[l], z.l[l], z.l[l]);
}
#undef V_MAP
#endif

/* d / 2 rounded half to even, per lane */
static inline vi v_half(vi x)
{
    return v_sra(v_add(x, v_and(v_sra(x, 1), v_splat(1))), 1);
}

/* ---- bytes ---- */
static inline uint64_t load64(const uint8_t *p)
{
    uint64_t w;
    __builtin_memcpy(&w, p, 8);
    return w;
}

static inline uint32_t load16(const uint8_t *p)
{
    uint16_t w;
    __builtin_memcpy(&w, p, 2);
    return w;
}

static inline uint32_t get16(const uint8_t *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8; }
static inline uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static inline uint64_t get64(const uint8_t *p) { return (uint64_t)get32(p) | (uint64_t)get32(p + 4) << 32; }

/* Records a failure in e; returns its code. */
static int fail_at(codec_core_error *e, int code, size_t byte, uint32_t index, uint64_t a, uint64_t b)
{
    e->code = code;
    e->byte = (uint32_t)byte;
    e->index = index;
    e->pad = 0;
    e->a = a;
    e->b = b;
    return code;
}

/* Records a failure of the frame k decodes; returns its code. */
static int fail(codec_core *k, int code, size_t byte, uint32_t index, uint64_t a, uint64_t b)
{
    return fail_at(&k->error, code, byte, index, a, b);
}

/* ---- CRC-32 ---- */
#if defined(__PCLMUL__) && defined(__SSE4_1__) && !defined(CODEC_CORE_PORTABLE)
/* Folding constants for the bit-reflected polynomial (x^k mod P, reflected, k per use below):
 * 4 x 128 bits at a time, 128 bits at a time, 64 -> 32 bits, then Barrett reduction with P' and
 * u' = floor(x^64 / P)'. Checked against zlib by the tests. */
static inline __m128i fold(__m128i x, __m128i k, __m128i data)
{
    return _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x, k, 0x00), _mm_clmulepi64_si128(x, k, 0x11)), data);
}

/* The CRC after p[0..n) (n >= 64) but for the n mod 16 bytes at the end, which *rest gets. */
static uint32_t crc_fold(uint32_t crc, const uint8_t *p, size_t n, size_t *rest)
{
    const __m128i k512 = _mm_set_epi64x(0x1c6e41596ll, 0x154442bd4ll), k128 = _mm_set_epi64x(0x0ccaa009ell, 0x1751997d0ll);
    __m128i x0 = _mm_loadu_si128((const __m128i *)(const void *)p), x1 = _mm_loadu_si128((const __m128i *)(const void *)(p + 16)),
            x2 = _mm_loadu_si128((const __m128i *)(const void *)(p + 32)), x3 = _mm_loadu_si128((const __m128i *)(const void *)(p + 48));
    x0 = _mm_xor_si128(x0, _mm_cvtsi32_si128((int)~crc));
    p += 64;
    n -= 64;
    for (; n >= 64; p += 64, n -= 64) {
        x0 = fold(x0, k512, _mm_loadu_si128((const __m128i *)(const void *)p));
        x1 = fold(x1, k512, _mm_loadu_si128((const __m128i *)(const void *)(p + 16)));
        x2 = fold(x2, k512, _mm_loadu_si128((const __m128i *)(const void *)(p + 32)));
        x3 = fold(x3, k512, _mm_loadu_si128((const __m128i *)(const void *)(p + 48)));
    }
    x0 = fold(fold(fold(x0, k128, x1), k128, x2), k128, x3);
    for (; n >= 16; p += 16, n -= 16) x0 = fold(x0, k128, _mm_loadu_si128((const __m128i *)(const void *)p));
    const __m128i mask32 = _mm_set_epi32(0, 0, 0, -1), k64 = _mm_set_epi64x(0, 0x163cd6124ll),
                  pu = _mm_set_epi64x(0x1f7011641ll, 0x1db710641ll);
    __m128i t = _mm_xor_si128(_mm_clmulepi64_si128(x0, k128, 0x10), _mm_srli_si128(x0, 8));            /* 128 -> 64 */
    t = _mm_xor_si128(_mm_clmulepi64_si128(_mm_and_si128(t, mask32), k64, 0x00), _mm_srli_si128(t, 4)); /* 64 -> 32 */
    __m128i b = _mm_and_si128(_mm_clmulepi64_si128(_mm_and_si128(t, mask32), pu, 0x10), mask32);
    b = _mm_xor_si128(_mm_clmulepi64_si128(b, pu, 0x00), t);
    *rest = n;
    return ~(uint32_t)_mm_extract_epi32(b, 1);
}
#endif

/* The CRC state c (inverted) after p[0..n): 8 bytes at a time (slicing by 8), then bytes. */
static uint32_t crc_sliced(uint32_t c, const uint8_t *p, size_t n)
{
    const uint32_t(*T)[256] = CRC_TABLE;
    for (; n >= 8; p += 8, n -= 8) {
        c ^= get32(p);
        const uint32_t d = get32(p + 4);
        c = T[7][c & 0xff] ^ T[6][(c >> 8) & 0xff] ^ T[5][(c >> 16) & 0xff] ^ T[4][c >> 24] ^ T[3][d & 0xff] ^
            T[2][(d >> 8) & 0xff] ^ T[1][(d >> 16) & 0xff] ^ T[0][d >> 24];
    }
    for (; n > 0; p++, n--) c = T[0][(c ^ *p) & 0xff] ^ (c >> 8);
    return c;
}

uint32_t codec_core_crc32(uint32_t crc, const uint8_t *p, size_t n)
{
#if defined(__PCLMUL__) && defined(__SSE4_1__) && !defined(CODEC_CORE_PORTABLE)
    if (n >= 64) {
        size_t rest;
        crc = crc_fold(crc, p, n, &rest);
        p += n - rest;
        n = rest;
    }
#endif
    return ~crc_sliced(~crc, p, n);
}

/* ---- state ---- */
size_t codec_core_size(void)
{
    return sizeof(codec_core);
}

void codec_core_reset(codec_core *k)
{
    k->key_valid = 0;
}

size_t codec_core_seg_len(uint32_t ns, uint32_t nverts)
{
    return ((size_t)ns + 7u) / 8u * 32u * nverts;
}

void codec_core_regions(codec_core *k, int32_t *q0, int32_t *q1, int16_t *d0, int16_t *d1)
{
    k->q[0] = q0;
    k->q[1] = q1;
    k->d[0] = d0;
    k->d[1] = d1;
}

/* Fills the constant lookups: the residuals (res, and cls for a keyframe's three axes at once) and
 * T_IDLE, whose every slot keeps the state (freq 4096, slot - start = slot), reads no raw bits, has
 * classes 0 and names T_IDLE next. For classes c (x, y, z; lane 3 unused) whose raw bits start at
 * offsets o = (0, c_x, c_x + c_y), bits o..o+15 of a 32-bit window w are (w 2^(16 - o)) >> 16
 * (mod 2^32): cls holds 2^(16 - o), the mask of c bits and m's leading one 2^(c - 1) (0 for c = 0). */
void codec_core_init(codec_core *k)
{
    for (int c = 0; c < 7; c++)
        for (int b = 0; b < 32; b++) {
            int f = b & ((1 << c) - 1), m = (1 << (c - 1 < 0 ? 0 : c - 1)) | (f >> 1);
            k->res[(c << 5) | b] = c == 0 || c == 6 ? 0 : f & 1 ? -m : m;
        }
    for (int f = 0; f < 512; f++) {
        int c[3] = { f & 7, (f >> 3) & 7, (f >> 6) & 7 };
        int o[3] = { 0, c[0], c[0] + c[1] };
        for (int a = 0; a < 4; a++) {
            int ok = a < 3 && c[0] < 6 && c[1] < 6 && c[2] < 6;
            k->cls[f][0][a] = ok ? 65536 >> o[a] : 0;
            k->cls[f][1][a] = ok ? (1 << c[a]) - 1 : 0;
            k->cls[f][2][a] = ok && c[a] ? 1 << (c[a] - 1) : 0;
        }
    }
    for (int s = 0; s < 4096; s++) {
        k->sinfo[T_IDLE * 4096 + s] = T_IDLE << 12;
        k->fb[T_IDLE * 4096 + s] = (4096 << 12) | s;
    }
    for (int i = 0; i < 8; i++) k->zero[i] = 0;
    k->key_valid = 0;
    k->key_slot = 0;
    k->error.code = 0;
}

/* ---- header ---- */
static inline double as_f64(uint64_t u)
{
    union {
        uint64_t u;
        double d;
    } x = { .u = u };
    return x.d;
}

static inline uint64_t as_u64(double d)
{
    union {
        double d;
        uint64_t u;
    } x = { .d = d };
    return x.u;
}

static inline float as_f32(uint32_t u)
{
    union {
        uint32_t u;
        float f;
    } x = { .u = u };
    return x.f;
}

int codec_core_header(codec_core_info *h, codec_core_error *e, const uint8_t *p, size_t len)
{
    if (len < HEADER) return fail_at(e, CODEC_E_SHORT_HEADER, 0, 0, len, HEADER);
    if (p[0] != CODEC_MAGIC[0] || p[1] != CODEC_MAGIC[1] || p[2] != CODEC_MAGIC[2] || p[3] != CODEC_MAGIC[3])
        return fail_at(e, CODEC_E_MAGIC, 0, 0, 0, 0);
    const uint32_t version = get16(p + CODEC_OFF_VERSION), flags = p[CODEC_OFF_FLAGS];
    if (version != CODEC_VERSION) return fail_at(e, CODEC_E_VERSION, CODEC_OFF_VERSION, 0, version, CODEC_VERSION);
    if (p[CODEC_OFF_CODEC] != CODEC_ID_STRAND && p[CODEC_OFF_CODEC] != CODEC_ID_HAIRMESH)
        return fail_at(e, CODEC_E_CODEC, CODEC_OFF_CODEC, 0, p[CODEC_OFF_CODEC], 0);
    if (flags & ~CODEC_FLAG_KEY) return fail_at(e, CODEC_E_FLAGS, CODEC_OFF_FLAGS, 0, flags, 0);
    const uint64_t time_bits = get64(p + CODEC_OFF_TIME);
    h->keyframe = flags & CODEC_FLAG_KEY;
    h->seq = get64(p + CODEC_OFF_SEQ);
    h->ref_seq = get64(p + CODEC_OFF_REF);
    h->sim_time = as_f64(time_bits);
    h->step = as_f64(get64(p + CODEC_OFF_STEP));
    h->max_error_m = as_f32(get32(p + CODEC_OFF_BOUND));
    h->nstrands_total = get32(p + CODEC_OFF_TOTAL);
    h->nstrands_sent = get32(p + CODEC_OFF_SENT);
    h->nverts = get32(p + CODEC_OFF_NVERTS);
    h->stride = get32(p + CODEC_OFF_STRIDE);
    h->payload_len = get32(p + CODEC_OFF_PAYLOAD);
    h->codec = p[CODEC_OFF_CODEC];
    h->pad2 = 0;
    h->sim_step = get64(p + CODEC_OFF_SIM_STEP);
    /* written out: a copy loop would become a call to memcpy, which the freestanding core lacks */
    h->head_pos[0] = as_f32(get32(p + CODEC_OFF_HEAD_POS));
    h->head_pos[1] = as_f32(get32(p + CODEC_OFF_HEAD_POS + 4));
    h->head_pos[2] = as_f32(get32(p + CODEC_OFF_HEAD_POS + 8));
    h->head_rot[0] = as_f32(get32(p + CODEC_OFF_HEAD_ROT));
    h->head_rot[1] = as_f32(get32(p + CODEC_OFF_HEAD_ROT + 4));
    h->head_rot[2] = as_f32(get32(p + CODEC_OFF_HEAD_ROT + 8));
    h->head_rot[3] = as_f32(get32(p + CODEC_OFF_HEAD_ROT + 12));
    if (h->keyframe ? h->ref_seq != h->seq : h->ref_seq >= h->seq) return fail_at(e, CODEC_E_REF, CODEC_OFF_REF, 0, 0, 0);
    if ((time_bits >> 52 & 0x7ffu) == 0x7ffu) return fail_at(e, CODEC_E_TIME, CODEC_OFF_TIME, 0, 0, 0);
    for (uint32_t i = 0; i < 7; i++) /* head position x, y, z, then rotation x, y, z, w */
        if ((get32(p + CODEC_OFF_HEAD_POS + 4 * i) >> 23 & 0xffu) == 0xffu)
            return fail_at(e, CODEC_E_HEAD, CODEC_OFF_HEAD_POS + 4 * i, i < 3 ? 0 : 1, 0, 0);
    double norm2 = 0.0;
    for (int i = 0; i < 4; i++) norm2 += (double)h->head_rot[i] * (double)h->head_rot[i];
    if (!(norm2 >= 1.0 - CODEC_HEAD_NORM_TOL && norm2 <= 1.0 + CODEC_HEAD_NORM_TOL))
        return fail_at(e, CODEC_E_HEAD, CODEC_OFF_HEAD_ROT, 2, as_u64(norm2), 0);
    if (!(h->max_error_m >= CODEC_MIN_ERROR && h->max_error_m <= CODEC_MAX_ERROR)) return fail_at(e, CODEC_E_BOUND, CODEC_OFF_BOUND, 0, 0, 0);
    if (!(h->step > 0.0 && h->step <= 2.0 * (double)h->max_error_m)) return fail_at(e, CODEC_E_STEP, CODEC_OFF_STEP, 0, 0, 0);
    if (h->nverts < 2 || h->nverts > CODEC_MAX_NVERTS) return fail_at(e, CODEC_E_NVERTS, CODEC_OFF_NVERTS, 0, 0, 0);
    if (h->stride < 1 || h->nstrands_total < 1 || (h->codec == CODEC_ID_HAIRMESH && h->stride != 1))
        return fail_at(e, CODEC_E_COUNTS, h->nstrands_total < 1 ? CODEC_OFF_TOTAL : CODEC_OFF_STRIDE, 0, 0, 0);
    const uint64_t sent = ((uint64_t)h->nstrands_total + h->stride - 1u) / h->stride;
    if (h->nstrands_sent != sent) return fail_at(e, CODEC_E_SENT, CODEC_OFF_SENT, 0, sent, 0);
    if ((uint64_t)h->nstrands_sent * h->nverts > CODEC_MAX_VERTICES)
        return fail_at(e, CODEC_E_TOO_MANY, CODEC_OFF_SENT, 0, 0, 0);
    if ((uint64_t)len != (uint64_t)HEADER + h->payload_len) return fail_at(e, CODEC_E_LENGTH, CODEC_OFF_PAYLOAD, 0, len, 0);
    return 0;
}

/* ---- motion and tables ---- */

/* Reads and checks a delta's rigid motion at p (frame byte at) into k->motion. */
static int read_motion(codec_core *k, const uint8_t *p, size_t at)
{
    for (uint32_t i = 0; i < 9; i++) {
        const int32_t r = (int16_t)get16(p + 2 * i);
        if (r < -CODEC_RHO_ONE || r > CODEC_RHO_ONE) return fail(k, CODEC_E_ROTATION, at + 2 * i, i, (uint64_t)(int64_t)r, 0);
        k->motion[i] = r;
    }
    for (uint32_t i = 0; i < 3; i++) {
        const int32_t t = (int32_t)get32(p + 20 + 4 * i);
        if (t < -CODEC_T_MAX || t > CODEC_T_MAX) return fail(k, CODEC_E_TRANSLATION, at + 20 + 4 * i, i, (uint64_t)(int64_t)t, 0);
        k->motion[9 + i] = t;
    }
    for (uint32_t i = 18; i < MOTION_BYTES; i++) {
        if (i == 20) i = 32;
        if (p[i]) return fail(k, CODEC_E_PADDING, at + i, i, 0, 0);
    }
    return 0;
}

/* LEB128 value of at most 2 bytes at p[*pos] (before end) of table t; -code on an error. */
static int64_t varint(codec_core *k, const uint8_t *p, size_t *pos, size_t end, uint32_t t)
{
    if (*pos >= end) return -fail(k, CODEC_E_TABLE_SHORT, *pos, t, 0, 0);
    const uint32_t b0 = p[(*pos)++];
    if (!(b0 & 0x80u)) return b0;
    if (*pos >= end) return -fail(k, CODEC_E_TABLE_SHORT, *pos, t, 0, 0);
    const uint32_t b1 = p[(*pos)++];
    if (b1 & 0x80u) return -fail(k, CODEC_E_TABLE_VARINT, *pos - 2u, t, 0, 0);
    return (b0 & 0x7fu) | b1 << 7;
}

/* The slot entry of symbol s in table t: for a vertex table the classes c0 | c1 << 3 | c2 << 6,
 * INFO_SLOW when an axis is escaped and the next vertex's table << 12 (T_FIRST after a root, the
 * body table by the largest class otherwise); for the mode table the mode. */
static uint32_t symbol_entry(uint32_t t, uint32_t s)
{
    if (t == T_MODE) return s;
    const uint32_t c0 = s % 7u, c1 = s / 7u % 7u, c2 = s / 49u;
    uint32_t m = c0 > c1 ? c0 : c1;
    m = m > c2 ? m : c2;
    const uint32_t next = t == T_ROOT ? T_FIRST : T_BODY + (m < 5u ? m : 5u);
    return c0 | c1 << 3 | c2 << 6 | (m == 6u ? INFO_SLOW : 0u) | next << 12;
}

/* Fills slots [start, start + f) of table t with entry e. */
static void fill_slots(codec_core *k, uint32_t t, uint32_t start, uint32_t f, uint32_t e)
{
    const uint32_t bits = t > 0 && e != INFO_UNUSED ? (e & 7u) + ((e >> 3) & 7u) + ((e >> 6) & 7u) : 0u;
    const uint32_t s = (t << 12) + start, hi = bits << 25 | f << 12;
    for (uint32_t i = 0; i < f; i++) {
        k->sinfo[s + i] = (uint16_t)e;
        k->fb[s + i] = (int32_t)(hi | i);
    }
}

/* Reads the nine probability tables at p[*pos, end) into the per-slot lookups. */
static int read_tables(codec_core *k, const uint8_t *p, size_t *pos, size_t end)
{
    for (uint32_t t = 0; t < NTABLES; t++) {
        const size_t at = *pos;
        int64_t used = varint(k, p, pos, end, t);
        if (used < 0) return (int)-used;
        if (used > NSYM) return fail(k, CODEC_E_TABLE_COUNT, at, t, (uint64_t)used, 0);
        if (used == 0) {
            fill_slots(k, t, 0, SCALE, INFO_UNUSED);
            continue;
        }
        uint32_t start = 0, next = 0;
        for (int64_t i = 0; i < used; i++) {
            const size_t sat = *pos;
            const int64_t gap = varint(k, p, pos, end, t);
            if (gap < 0) return (int)-gap;
            const size_t fat = *pos;
            const int64_t f = varint(k, p, pos, end, t);
            if (f < 0) return (int)-f;
            if (gap >= NSYM - next) return fail(k, CODEC_E_TABLE_SYMBOL, sat, t, 0, 0);
            const uint32_t s = next + (uint32_t)gap;
            if (f == 0 || f > SCALE - start) return fail(k, CODEC_E_TABLE_FREQ, fat, t, (uint64_t)f, 0);
            fill_slots(k, t, start, (uint32_t)f, symbol_entry(t, s));
            start += (uint32_t)f;
            next = s + 1u;
        }
        if (start != SCALE) return fail(k, CODEC_E_TABLE_SUM, at, t, start, 0);
    }
    return 0;
}

/* ---- entropy decoding ---- */

/* The readers: rANS word position, raw bits (from bits, bp read). */
typedef struct reader {
    const uint8_t *rp;
    const uint8_t *bits;
    uint32_t bp;
} reader;

/* The residuals of a vertex symbol with entry f whose raw bits start at bp of bits, any class
 * (escapes included), to r[0], r[as], r[2 as]. Returns the bit position after them, or -1 (f from
 * an unused table) or -2 (an escape exponent above 24). */
__attribute__((noinline)) static int64_t slow_symbol(const codec_core *k, uint32_t f, const uint8_t *bits,
                                                     uint32_t bp, int32_t *r, int as)
{
    if (f == INFO_UNUSED) return -1;
    for (int ax = 0; ax < 3; ax++) {
        uint32_t c = (f >> (3 * ax)) & 7;
        uint64_t w = load64(bits + (bp >> 3)) >> (bp & 7);
        int32_t v;
        if (c < 6) {
            v = k->res[(c << 5) | (uint32_t)(w & 31)];
            bp += c;
        } else {
            /* escape: e - 5 (5 bits), the sign, then the e bits of m below its leading one */
            uint32_t e = (uint32_t)(w & 31);
            if (e > CODEC_ESC_MAX) return -2;
            e += 5;
            uint32_t neg = (uint32_t)(w >> 5) & 1;
            bp += 6;
            w = load64(bits + (bp >> 3)) >> (bp & 7);
            int32_t m = (int32_t)((1u << e) | ((uint32_t)w & ((1u << e) - 1)));
            bp += e;
            v = neg ? -m : m;
        }
        r[as * ax] = v;
    }
    return bp;
}

/* slow_symbol for a keyframe's raw pass (to r[0..2]), without branches on the classes or the
 * bits: the escapes of keyframes are common and unpredictable. */
static inline __attribute__((always_inline)) int64_t key_slow_symbol(const codec_core *k, uint32_t f,
                                                                     const uint8_t *bits, uint32_t bp, int32_t *r)
{
    if (f == INFO_UNUSED) return -1;
    uint32_t bad = 0;
    for (int ax = 0; ax < 3; ax++) {
        uint32_t c = (f >> (3 * ax)) & 7;
        uint64_t w = load64(bits + (bp >> 3)) >> (bp & 7);
        /* an escape: e - 5 (5 bits), the sign, then the e bits of m below its leading one (e - 5
         * above 24 is refused; e is taken modulo 32 only to keep the shifts defined), and the
         * table lookup of any other class (res has a row of zeros for c = 6) */
        uint32_t lo = (uint32_t)w & 31, e = (lo + 5) & 31, esc = c == 6;
        uint32_t m = (1u << e) | ((uint32_t)(w >> 6) & ((1u << e) - 1));
        uint32_t neg = 0u - ((uint32_t)(w >> 5) & 1);
        int32_t ve = (int32_t)((m ^ neg) - neg), vc = k->res[(c << 5) | lo];
        bad |= esc & (lo > CODEC_ESC_MAX);
        r[ax] = esc ? ve : vc;
        bp += esc ? 6 + e : c;
    }
    return bad ? -2 : (int64_t)bp;
}

/* The group's failure codes, by slow_symbol's result. */
#define SYMBOL_FAIL(nb) ((nb) == -1 ? CODEC_E_SYMBOL : CODEC_E_ESCAPE)

/* The residuals of a vertex symbol with entry f (bits 0..15) and nb raw bits (when no axis is
 * escaped) at the readers' bp, to rr[0], rr[RAXIS], rr[2 RAXIS]; on an error returns its code. */
#define RAW_SYMBOL(f, nb, rr)                                                       \
    do {                                                                            \
        if ((f) & INFO_SLOW) {                                                      \
            int64_t nb_ = slow_symbol(k, f, bits, bp, rr, RAXIS);                   \
            if (nb_ < 0) return SYMBOL_FAIL(nb_);                                   \
            bp = (uint32_t)nb_;                                                     \
        } else {                                                                    \
            uint32_t w = (uint32_t)(load64(bits + (bp >> 3)) >> (bp & 7));          \
            uint32_t c0 = (f) & 7, c1 = ((f) >> 3) & 7, c2 = ((f) >> 6) & 7;        \
            (rr)[0] = k->res[(c0 << 5) | (w & 31)];                                 \
            w >>= c0;                                                               \
            (rr)[RAXIS] = k->res[(c1 << 5) | (w & 31)];                             \
            w >>= c1;                                                               \
            (rr)[2 * RAXIS] = k->res[(c2 << 5) | (w & 31)];                         \
            bp += nb;                                                               \
        }                                                                           \
    } while (0)

/* One rANS step of a lane whose state X is x | table << 44 (table: the one to read the symbol
 * with): i = the slot's table index; X becomes the next x (table bits clear); the word reader
 * advances. */
#define RANS_STEP(X, i, fb)                                                         \
    do {                                                                            \
        uint32_t x_ = (uint32_t)(X);                                                \
        i = (uint32_t)((X) >> 32) | (x_ & 4095);                                    \
        fb = (uint32_t)k->fb[i];                                                    \
        x_ = ((fb >> 12) & 8191) * (x_ >> 12) + (fb & 4095);                        \
        uint32_t nr_ = x_ < 65536, xw_ = (x_ << 16) | load16(rp), m_ = 0u - nr_;   \
        x_ = (xw_ & m_) | (x_ & ~m_); /* a mask, not ?: (gcc would branch) */       \
        rp += nr_ << 1;                                                             \
        X = x_;                                                                     \
    } while (0)

/* The rANS step of lane L's vertex symbol: its entry to f and its table slot to fb, the next
 * table into X##L. */
#define LANE_SYMBOL(L, f, fb)                                                       \
    do {                                                                            \
        uint32_t i;                                                                 \
        RANS_STEP(X##L, i, fb);                                                     \
        f = k->sinfo[i];                                                            \
        X##L |= (uint64_t)(f & INFO_NEXT) << 32;                                    \
    } while (0)

/* A vertex symbol of lane L at the vertex whose residuals start at rv (RLANE, RAXIS: the strides
 * of a lane and an axis there): residuals to rv[RLANE L + RAXIS axis], the next table into X##L. */
#define VERTEX_LANE(L)                                                              \
    do {                                                                            \
        uint32_t f, fb;                                                             \
        LANE_SYMBOL(L, f, fb);                                                      \
        RAW_SYMBOL(f, fb >> 25, rv + RLANE * (L));                                  \
    } while (0)

/* The rANS step of lane L's vertex symbol: its raw-bit count << 25 | entry to sp[L], the next
 * table into X##L. */
#define RANS_LANE(L)                                                                \
    do {                                                                            \
        uint32_t f, fb;                                                             \
        LANE_SYMBOL(L, f, fb);                                                      \
        sp[L] = (fb & 0xfe000000u) | f;                                             \
    } while (0)

/* The raw bits of lane L's symbol sp[L] (RANS_LANE) at a keyframe's vertex whose residuals start
 * at rv: x, y, z to rv[4 L + 0..2] (and 0 to rv[4 L + 3] unless an axis is escaped); without an
 * escape, the three axes at once (k->cls). */
#define KEY_RAW_LANE(L)                                                             \
    do {                                                                            \
        uint32_t e = sp[L];                                                         \
        int32_t *rr = rv + 4 * (L);                                                 \
        if (e & INFO_SLOW) {                                                        \
            int64_t nb_ = key_slow_symbol(k, e & 0xffff, bits, bp, rr);             \
            if (nb_ < 0) return SYMBOL_FAIL(nb_);                                   \
            bp = (uint32_t)nb_;                                                     \
        } else {                                                                    \
            uint32_t w_;                                                            \
            __builtin_memcpy(&w_, bits + (bp >> 3), 4);                             \
            const int32_t(*cd)[4] = k->cls[e & 511];                                \
            vi b_ = v_mul(v_splat((int32_t)(w_ >> (bp & 7))), v_load(cd[0]));       \
            b_ = v_and(v_srl(b_, 16), v_load(cd[1]));                               \
            vi s_ = v_and(b_, v_splat(1));                                          \
            vi m_ = v_or(v_srl(b_, 1), v_load(cd[2]));                              \
            v_store(rr, v_add(v_xor(m_, v_neg(s_)), s_));                           \
            bp += e >> 25;                                                          \
        }                                                                           \
    } while (0)

/* The mode symbol of lane L to k->mode[L]; X##L then reads its next symbol with table t, or
 * T_IDLE for a lane past the last strand. */
#define MODE_LANE(L, t)                                                             \
    do {                                                                            \
        uint32_t i, fb;                                                             \
        RANS_STEP(X##L, i, fb);                                                     \
        (void)fb;                                                                   \
        k->mode[L] = k->sinfo[i];                                                   \
        X##L |= (uint64_t)(n > (L) ? (t) : T_IDLE) << 44;                           \
    } while (0)

/* The state of lane L from k->state, to read table t (T_IDLE for a lane past the last strand). */
#define LANE_STATE(L, t) ((uint32_t)k->state[L] | (uint64_t)(n > (L) ? (t) : T_IDLE) << 44)

/* Decodes the symbols of one group of n strands (lanes from n on idle) of a keyframe (key: a
 * constant) or a delta: the modes to k->mode (below 3 or 4; idle lanes 8), the residuals to k->r
 * (a keyframe's [v][lane][x, y, z, lane 3], a delta's [v][axis][lane]). A keyframe's vertex
 * symbols take two passes, each with few live values: the rANS steps (to k->sym; a lane that
 * meets an unused table goes on idle), then the raw bits with the escapes (common in keyframes)
 * decoded without branches; a delta's take one pass. The readers continue from rd and the lane
 * states in k->state and are left there. Returns 0 or the code of an error (that of the first
 * bad symbol in coding order; rd->rp then is after the modes, rd->bp unchanged). */
static inline __attribute__((always_inline)) int group_symbols(codec_core *k, reader *rd, int n, int nverts,
                                                               const int key)
{
    const int RLANE = key ? 4 : 1, RAXIS = key ? 1 : 8, RVERT = key ? 32 : 24, nmodes = key ? 3 : 4;
    const uint8_t *rp = rd->rp, *bits = rd->bits;
    uint32_t bp = rd->bp;
    uint64_t X0 = LANE_STATE(0, 0), X1 = LANE_STATE(1, 0), X2 = LANE_STATE(2, 0), X3 = LANE_STATE(3, 0);
    uint64_t X4 = LANE_STATE(4, 0), X5 = LANE_STATE(5, 0), X6 = LANE_STATE(6, 0), X7 = LANE_STATE(7, 0);
    MODE_LANE(0, 1); MODE_LANE(1, 1); MODE_LANE(2, 1); MODE_LANE(3, 1);
    MODE_LANE(4, 1); MODE_LANE(5, 1); MODE_LANE(6, 1); MODE_LANE(7, 1);
    rd->rp = rp;
    /* a mode out of range (or from an unused table) ends the frame before its vertices */
    for (int l = 0; l < n; l++) {
        int f = k->mode[l];
        if (f >= nmodes) return f == INFO_UNUSED ? CODEC_E_SYMBOL : CODEC_E_MODE;
    }
    for (int l = n; l < 8; l++) k->mode[l] = 8;
    int32_t *rv = k->r, *rend = k->r + RVERT * nverts;
    if (key) {
        uint32_t *sp = k->sym, *send = k->sym + 8 * nverts;
        for (; sp < send; sp += 8) {
            RANS_LANE(0); RANS_LANE(1); RANS_LANE(2); RANS_LANE(3);
            RANS_LANE(4); RANS_LANE(5); RANS_LANE(6); RANS_LANE(7);
        }
        for (sp = k->sym; sp < send; sp += 8, rv += RVERT) {
            KEY_RAW_LANE(0); KEY_RAW_LANE(1); KEY_RAW_LANE(2); KEY_RAW_LANE(3);
            KEY_RAW_LANE(4); KEY_RAW_LANE(5); KEY_RAW_LANE(6); KEY_RAW_LANE(7);
        }
    } else {
        for (; rv < rend; rv += RVERT) {
            VERTEX_LANE(0); VERTEX_LANE(1); VERTEX_LANE(2); VERTEX_LANE(3);
            VERTEX_LANE(4); VERTEX_LANE(5); VERTEX_LANE(6); VERTEX_LANE(7);
        }
    }
    k->state[0] = (int32_t)X0; k->state[1] = (int32_t)X1; k->state[2] = (int32_t)X2;
    k->state[3] = (int32_t)X3; k->state[4] = (int32_t)X4; k->state[5] = (int32_t)X5;
    k->state[6] = (int32_t)X6; k->state[7] = (int32_t)X7;
    rd->rp = rp;
    rd->bp = bp;
    return 0;
}

/* group_symbols of a keyframe's group and of a delta's, as functions of their own. */
__attribute__((noinline)) static int key_symbols(codec_core *k, reader *rd, int n, int nverts)
{
    return group_symbols(k, rd, n, nverts, 1);
}

__attribute__((noinline)) static int delta_symbols(codec_core *k, reader *rd, int n, int nverts)
{
    return group_symbols(k, rd, n, nverts, 0);
}

/* ---- reconstruction ---- */

/* Negative when q is outside [-QMAX, QMAX]. */
static inline int32_t out_of_range(int32_t q)
{
    return (int32_t)(((uint32_t)q + QMAX) | ((uint32_t)QMAX - (uint32_t)q));
}

/* The vertex (x, y, z: 4 lanes each, float bits) of 4 lanes to o[0..3] at v floats on; with
 * 16-byte stores (the fourth float lands where the lane's next vertex goes) unless last (the
 * lane's last vertex: 12 bytes exactly). */
static inline void store_vertex(vi x, vi y, vi z, float *const *o, int v, int last)
{
    vi l[4];
    v_transpose(x, y, z, l);
    for (int i = 0; i < 4; i++) {
        if (!last) v_store(o[i] + v, l[i]);
        else v_store3(o[i] + v, l[i]);
    }
}

/* The x, y, z lanes of v (the fourth is not stored) to p: 16 bytes (the fourth lands where the
 * next vertex goes) unless last (the strand's last vertex: 12 bytes exactly). */
static inline void store_xyz(void *p, vi v, int last)
{
    if (!last) v_store(p, v);
    else v_store3(p, v);
}

/* Vertices 2 on of a keyframe strand (see rebuild_key; kind as there, constant per call), the
 * x, y, z of a vertex in lanes 0..2 of one vector (lane 3 is not used). Returns the unsigned
 * maximum of |q| (per lane; |-2^31| counts as 2^31). */
static inline __attribute__((always_inline)) vi key_body(const int32_t *r, const int32_t *pn, int32_t *pc,
                                                         float *po, int16_t *pd, int nverts, vstep st, vi a,
                                                         vi b, vi n, const int kind)
{
    vi bad = v_splat(0), e = b;
    for (int v = 2; v < nverts; v++) {
        vi q, rv = v_load(r + 32 * v);
        if (kind == 1) {
            vi kn = n;
            n = v_load(pn + 3 * v);
            q = v_add(a, v_sub(n, kn));
        } else if (kind == 3 && v > 2) {
            q = v_add(a, v_half(v_sub(a, e)));
        } else {
            q = v_sub(v_add(a, a), b);
        }
        q = v_add(q, rv);
        bad = v_maxu(bad, v_abs(q));
        int last = v == nverts - 1;
        store_xyz(pc + 3 * v, q, last);
        store_xyz(po + 3 * v, v_tofloat(q, st), last);
        v_store_seg(pd + 32 * v, v_sub(q, a));
        e = b;
        b = a;
        a = q;
    }
    return bad;
}

/* Rebuilds keyframe strand j (lane l of its group; mode < 3) from the residuals in k->r (lane l's
 * at 4 l of each vertex's 32): the lattice coordinates to pc (nverts vertices), float32(q * step)
 * to po, its clamped segments to pd (the group's in the layout of segments_idle, plus 2 l). The
 * neighbour N is the previous strand (at pc - 3 nverts, already rebuilt), zeros for the first.
 * Root N[0] + R; vertex 1 P[0] + N[1] - N[0]; from vertex 2 mode 1 with a neighbour
 * P[v-1] + N[v] - N[v-1], mode 2 linear at vertex 2 and then smooth linear
 * P[v-1] + half(P[v-1] - P[v-3]), else linear 2 P[v-1] - P[v-2]. Returns -1 when a coordinate is
 * out of range, else 0. */
static int32_t rebuild_key(const codec_core *k, int l, int mode, int j, int32_t *pc, float *po, int16_t *pd,
                           int nverts, double step)
{
    const int32_t *pn = j > 0 ? pc - 3 * nverts : k->zero;
    const int32_t *r = k->r + 4 * l;
    vstep st = v_step(step);
    vi k0 = v_load(pn), n = v_load(pn + 3);
    vi b = v_add(k0, v_load(r));
    vi a = v_add(v_add(b, v_sub(n, k0)), v_load(r + 32));
    vi bad = v_maxu(v_abs(b), v_abs(a));
    int last = nverts == 2;
    store_xyz(pc, b, 0);
    store_xyz(po, v_tofloat(b, st), 0);
    store_xyz(pc + 3, a, last);
    store_xyz(po + 3, v_tofloat(a, st), last);
    pd[0] = pd[1] = pd[16] = pd[17] = 0; /* vertex 0 */
    v_store_seg(pd + 32, v_sub(a, b));
    /* kind: 1 neighbour, 2 linear, 3 linear once, then smooth linear */
    if (mode == 1 && j > 0) bad = v_maxu(bad, key_body(r, pn, pc, po, pd, nverts, st, a, b, n, 1));
    else if (mode == 2) bad = v_maxu(bad, key_body(r, pn, pc, po, pd, nverts, st, a, b, n, 3));
    else bad = v_maxu(bad, key_body(r, pn, pc, po, pd, nverts, st, a, b, n, 2));
    return v_gtu(bad, v_splat(QMAX)) & 7 ? -1 : 0;
}

/* Vertices 1 on of a delta group's 8 strands at once (the roots are in k->root), from the
 * moved segments S[v] = (rho d[v] + 8192) >> 14 of the held keyframe's clamped segments d (pd:
 * the group's, laid out as segments_idle says): vertex 1 and mode 0 P[v-1] + S[v], mode 1 that
 * plus w = P[v-1] - P[v-2] - S[v-1] (the sum of the residuals since vertex 1), mode 2 linear,
 * mode 3 linear at vertex 2 and then smooth linear; plus the residual. general: 0 when every
 * lane's mode is 0 or 1. o[l]: lane l's output (float32(q * step)). Returns -1 when a coordinate
 * is out of range, else 0. */
static inline __attribute__((always_inline)) int32_t delta_lanes(const codec_core *k, const int16_t *pd, int nverts,
                                                                 double step, float *const *o, const int general)
{
    const int32_t *m = k->motion;
    /* per axis the pairs (rho_0, rho_1) and (rho_2, 8192) of its row, as int16 pairs */
    vi r01[3], r2c[3];
    for (int ax = 0; ax < 3; ax++) {
        r01[ax] = v_splat((int32_t)(((uint32_t)m[3 * ax] & 0xffffu) | (uint32_t)m[3 * ax + 1] << 16));
        r2c[ax] = v_splat((int32_t)(((uint32_t)m[3 * ax + 2] & 0xffffu) | 8192u << 16));
    }
    vstep st = v_step(step);
    vi lim = v_splat(QMAX);
    vi a[6], b[6], e[6], w[6], mw[2], m2[2], mlo[2], mseg[2], mlin[2], bad = v_splat(0);
    for (int h = 0; h < 2; h++) {
        vi md = v_load(k->mode + 4 * h);
        mw[h] = v_eq(md, v_splat(1));
        m2[h] = v_eq(md, v_splat(2));
        mlo[h] = v_lt(md, v_splat(2));
        mseg[h] = v_splat(-1);
        mlin[h] = v_splat(0);
    }
    for (int i = 0; i < 6; i++) {
        a[i] = v_load(k->root + 4 * i);
        b[i] = a[i];
        e[i] = a[i];
        w[i] = v_splat(0);
    }
    const int32_t *rv = k->r + 24;
    for (int v = 1; v < nverts; v++, rv += 24) {
        const int16_t *dv = pd + 32 * v;
        vi d01[2], d2c[2];
        for (int h = 0; h < 2; h++) {
            d01[h] = v_load(dv + 8 * h);
            d2c[h] = v_load(dv + 16 + 8 * h);
        }
        for (int ax = 0; ax < 3; ax++) {
            for (int h = 0; h < 2; h++) {
                int i = 2 * ax + h;
                vi s = v_add(v_dot16(d01[h], r01[ax]), v_dot16(d2c[h], r2c[ax]));
                vi r = v_load(rv + 4 * i);
                vi q = v_add(v_add(a[i], v_sra(s, 14)), w[i]);
                if (general) {
                    vi lin = v_sub(v_add(a[i], a[i]), b[i]);
                    vi sm = v_add(a[i], v_half(v_sub(a[i], e[i])));
                    q = v_sel(q, v_sel(lin, sm, mlin[h]), mseg[h]);
                    e[i] = b[i];
                    b[i] = a[i];
                }
                q = v_add(q, r);
                w[i] = v_add(w[i], v_and(r, mw[h]));
                bad = v_or(bad, v_or(v_add(q, lim), v_sub(lim, q)));
                a[i] = q;
            }
        }
        int last = v == nverts - 1;
        store_vertex(v_tofloat(a[0], st), v_tofloat(a[2], st), v_tofloat(a[4], st), o, 3 * v, last);
        store_vertex(v_tofloat(a[1], st), v_tofloat(a[3], st), v_tofloat(a[5], st), o + 4, 3 * v, last);
        if (general) {
            for (int h = 0; h < 2; h++) {
                mseg[h] = mlo[h];
                /* linear at vertex 2 for modes 2 and 3, then for mode 2 only */
                mlin[h] = v == 1 ? v_not(mlo[h]) : m2[h];
            }
        }
    }
    return v_signs(bad) ? -1 : 0;
}

/* Rebuilds the n strands from g of a delta group (lanes past n: zero residuals, roots and
 * segments, output to k->dump): the roots one after another (K'[0] + R, plus N[0] - KN'[0] after
 * the first strand; gn, gkn: the previous strand's root and moved root, which this group's last
 * strand replaces), then delta_lanes. keyq: the held keyframe's lattice; pd: its clamped
 * segments for this group. Returns -1 when a coordinate is out of range, else 0. */
static int32_t rebuild_delta_group(codec_core *k, int g, int n, int nverts, const int32_t *keyq, const int16_t *pd,
                                   float *out, double step, int32_t *gn, int32_t *gkn)
{
    const int32_t *m = k->motion;
    int32_t bad = 0;
    float *o[8];
    int general = 0;
    for (int l = 0; l < 8; l++) {
        if (l >= n) {
            k->root[l] = k->root[8 + l] = k->root[16 + l] = 0;
            o[l] = k->dump;
            continue;
        }
        int j = g + l;
        const int32_t *pk = keyq + 3 * nverts * j;
        o[l] = out + 3 * nverts * j;
        for (int ax = 0; ax < 3; ax++) {
            /* the moved root K'[0] (exact in 64 bits, clamped to |K'| < 2^26) */
            int64_t s = (int64_t)m[3 * ax] * pk[0] + (int64_t)m[3 * ax + 1] * pk[1] + (int64_t)m[3 * ax + 2] * pk[2] + 8192;
            int64_t x = (s >> 14) + m[9 + ax];
            int32_t lm = (int32_t)(x < -QMAX ? -QMAX : x > QMAX ? QMAX : x);
            uint32_t b = (uint32_t)lm + (uint32_t)k->r[8 * ax + l];
            if (j > 0) b += (uint32_t)gn[ax] - (uint32_t)gkn[ax];
            gn[ax] = (int32_t)b;
            gkn[ax] = lm;
            bad |= out_of_range((int32_t)b);
            k->root[8 * ax + l] = (int32_t)b;
            o[l][ax] = (float)((double)(int32_t)b * step);
        }
        general |= k->mode[l] >= 2;
    }
    /* root[] is axis-major, lane-minor: a[2 ax + h] = root[8 ax + 4 h ..] */
    if (general) return (bad < 0 ? -1 : 0) | delta_lanes(k, pd, nverts, step, o, 1);
    return (bad < 0 ? -1 : 0) | delta_lanes(k, pd, nverts, step, o, 0);
}

/* The clamped segments of a keyframe lie per group of 8 strands and vertex in 32 int16, laid out
 * for 16-bit multiply-adds (delta_lanes): lane l's (d_0, d_1) at 2 l, its (d_2, 1) at 16 + 2 l,
 * where d = clamp15(L[v] - L[v-1]); vertex 0 and lanes past the last strand are 0 (rebuild_key
 * writes a strand's). Zeros lanes n..7 of a group's pd. */
static void segments_idle(int16_t *pd, int n, int nverts)
{
    for (int v = 0; v < nverts; v++) {
        for (int l = n; l < 8; l++) {
            pd[32 * v + 2 * l] = pd[32 * v + 2 * l + 1] = 0;
            pd[32 * v + 16 + 2 * l] = pd[32 * v + 17 + 2 * l] = 0;
        }
    }
}

/* Decodes the strands of the frame at p (header in k->info; the rANS words from wpos to wend,
 * the raw bits from there, bavail bits) into out and, for a keyframe, the free slots. */
static int decode_groups(codec_core *k, const uint8_t *p, const uint8_t *wpos, const uint8_t *wend, uint32_t bavail,
                         float *out)
{
    const codec_core_info *h = &k->info;
    const int key = (int)h->keyframe, ns = (int)h->nstrands_sent, nverts = (int)h->nverts, per = 3 * nverts;
    const int32_t *keyq = k->q[k->key_slot];
    const int16_t *dkey = k->d[k->key_slot];
    int32_t *curq = k->q[k->key_slot ^ 1u];
    int16_t *dcur = k->d[k->key_slot ^ 1u];
    reader rd = { wpos, wend, 0 };
    int32_t gn[3] = { 0, 0, 0 }, gkn[3] = { 0, 0, 0 };
    for (int g = 0; g < ns; g += 8) {
        int n = ns - g < 8 ? ns - g : 8;
        int rc = key ? key_symbols(k, &rd, n, nverts) : delta_symbols(k, &rd, n, nverts);
        if (rc) return fail(k, rc, (size_t)(rd.rp - p), (uint32_t)g, 0, 0);
        if (rd.rp > wend) return fail(k, CODEC_E_OVERRUN, (size_t)(wend - p), (uint32_t)g, 0, 0);
        if (rd.bp > bavail) return fail(k, CODEC_E_BITS, (size_t)(wend - p), (uint32_t)g, bavail, rd.bp);
        int32_t bad = 0;
        if (key) {
            int16_t *pd = dcur + 4 * nverts * g;
            for (int l = 0; l < n; l++) {
                int j = g + l;
                bad |= rebuild_key(k, l, k->mode[l], j, curq + per * j, out + per * j, pd + 2 * l, nverts, h->step);
            }
            segments_idle(pd, n, nverts);
        } else {
            bad = rebuild_delta_group(k, g, n, nverts, keyq, dkey + 4 * nverts * g, out, h->step, gn, gkn);
        }
        if (bad < 0) return fail(k, CODEC_E_VALUE, (size_t)(wend - p) + rd.bp / 8u, (uint32_t)g, 0, 0);
    }
    if (rd.rp != wend) return fail(k, CODEC_E_END, (size_t)(rd.rp - p), 0, 0, 0);
    for (int l = 0; l < 8; l++)
        if ((uint32_t)k->state[l] != CODEC_RANS_L) return fail(k, CODEC_E_END, (size_t)(wend - p), (uint32_t)l, 0, 0);
    if (bavail - rd.bp >= 8) return fail(k, CODEC_E_BITS, (size_t)(wend - p), 0, bavail, rd.bp);
    return 0;
}

int codec_core_check(codec_core *k, const uint8_t *p, size_t len)
{
    int rc = codec_core_header(&k->info, &k->error, p, len);
    if (rc) return rc;
    const codec_core_info *h = &k->info;
    if (codec_core_crc32(codec_core_crc32(0, p, CODEC_OFF_CRC), p + HEADER, h->payload_len) != get32(p + CODEC_OFF_CRC))
        return fail(k, CODEC_E_CRC, CODEC_OFF_CRC, 0, 0, 0);
    if (!h->keyframe) {
        const codec_core_info *key = &k->key;
        if (!k->key_valid || key->seq != h->ref_seq) return fail(k, CODEC_E_NO_KEY, CODEC_OFF_REF, 0, 0, 0);
        if (key->codec != h->codec || key->nstrands_total != h->nstrands_total || key->nverts != h->nverts ||
            key->stride != h->stride || key->step != h->step)
            return fail(k, CODEC_E_KEY_LAYOUT, CODEC_OFF_STEP, 0, 0, 0);
    }
    return 0;
}

/* *d = *s field by field: a struct copy this large would become a call to memcpy, which the
 * freestanding core lacks. */
static void copy_info(codec_core_info *d, const codec_core_info *s)
{
    d->seq = s->seq;
    d->ref_seq = s->ref_seq;
    d->sim_time = s->sim_time;
    d->step = s->step;
    d->max_error_m = s->max_error_m;
    d->keyframe = s->keyframe;
    d->nstrands_total = s->nstrands_total;
    d->nstrands_sent = s->nstrands_sent;
    d->nverts = s->nverts;
    d->stride = s->stride;
    d->payload_len = s->payload_len;
    d->codec = s->codec;
    d->pad2 = 0;
    d->sim_step = s->sim_step;
    d->head_pos[0] = s->head_pos[0];
    d->head_pos[1] = s->head_pos[1];
    d->head_pos[2] = s->head_pos[2];
    d->head_rot[0] = s->head_rot[0];
    d->head_rot[1] = s->head_rot[1];
    d->head_rot[2] = s->head_rot[2];
    d->head_rot[3] = s->head_rot[3];
}

int codec_core_decode(codec_core *k, const uint8_t *p, size_t len, float *out)
{
    const codec_core_info *h = &k->info;
    int rc;
    size_t pos = HEADER;
    if (!h->keyframe) {
        if (len - pos < MOTION_BYTES) return fail(k, CODEC_E_NO_MOTION, pos, 0, 0, 0);
        rc = read_motion(k, p + pos, pos);
        if (rc) return rc;
        pos += MOTION_BYTES;
    }
    rc = read_tables(k, p, &pos, len);
    if (rc) return rc;
    if (len - pos < 4) return fail(k, CODEC_E_NO_STREAM, pos, 0, 0, 0);
    const uint32_t rans_len = get32(p + pos);
    pos += 4;
    if (rans_len < CODEC_RANS_HEAD || rans_len % 2u || rans_len > len - pos)
        return fail(k, CODEC_E_STREAM_LEN, pos - 4, 0, rans_len, len - pos);
    for (uint32_t l = 0; l < LANES; l++) {
        const uint32_t x = get32(p + pos + 4 * l);
        if (x < CODEC_RANS_L) return fail(k, CODEC_E_STATE, pos + 4 * l, l, x, 0);
        k->state[l] = (int32_t)x;
    }
    const size_t rend = pos + rans_len;
    if (len - rend > (0xffffffffu - (1u << 20)) / 8u) /* more raw bits than any frame uses */
        return fail(k, CODEC_E_BITS, rend, 0, (uint64_t)(len - rend) * 8u, 0);
    rc = decode_groups(k, p, p + pos + CODEC_RANS_HEAD, p + rend, (uint32_t)(len - rend) * 8u, out);
    if (rc) return rc;
    if (h->keyframe) {
        k->key_slot ^= 1u;
        copy_info(&k->key, h);
        k->key_valid = 1;
    }
    return 0;
}
