/* codec: a group's residuals into vertex symbols (magnitude classes) and raw bits, and their
 * emission vertex by vertex across the lanes, with escapes and the symbol histogram. */
#include "codec_simd.h"

static inline uint32_t mag(int32_t r)
{
    return r < 0 ? 0u - (uint32_t)r : (uint32_t)r;
}

/* Field of residual r with class c < 6: sign, then the bits below the leading one. */
static inline uint32_t field(int32_t r, uint32_t c)
{
    return ((mag(r) << 1) | ((uint32_t)r >> 31)) & ((1u << c) - 1u);
}

/* Class of magnitude m as the vector path computes it: floor(log2(2 m + 1)) capped at 6. */
static inline uint32_t class_of(uint32_t m)
{
    union { float f; uint32_t u; } v = { .f = (float)(int32_t)(2u * (m < 64u ? m : 64u) + 1u) };
    uint32_t c = (v.u >> 23) - 127u;
    return c < CODEC_ESCAPE ? c : CODEC_ESCAPE;
}

/* Raw bits of residual r: class c < 6 as c bits (the sign, then the bits below the leading one),
 * an escape (m >= 32) as CODEC_ESC_BITS bits of e - 5 (e = floor(log2 m)), the sign and the e
 * bits below the leading one; stored as the low 32 bits, the rest, and the count at x[0], x[8],
 * x[16] (one lane of codec_tokens.xbits). */
static inline void axis_bits(int32_t r, uint32_t *x)
{
    const uint32_t m = mag(r), c = class_of(m);
    uint64_t w = field(r, c < CODEC_ESCAPE ? c : 0);
    uint32_t n = c;
    if (c == CODEC_ESCAPE) {
        const uint32_t ex = 31u - (uint32_t)__builtin_clz(m);
        w = (uint64_t)(ex - 5u) | (uint64_t)((uint32_t)r >> 31) << CODEC_ESC_BITS |
            (uint64_t)(m - (1u << ex)) << (CODEC_ESC_BITS + 1u);
        n = CODEC_ESC_BITS + 1u + ex;
    }
    x[0] = (uint32_t)w;
    x[CODEC_GROUP] = (uint32_t)(w >> 32);
    x[2u * CODEC_GROUP] = n;
}

/* Residual of vertex v, axis a, lane l: the root's, else the candidate of the lane's mode. */
static inline int32_t resid(const codec_tokens *t, uint32_t v, uint32_t a, uint32_t l)
{
    return v ? t->cand[CODEC_CAT(v, a, t->mode[l], l)] : t->root[a * CODEC_GROUP + l];
}

/* The vector path's loop with the 8 lanes as an inner loop. */
static uint32_t tokens_portable(const codec_tokens *t, uint32_t nv, bool all)
{
    uint32_t base[CODEC_GROUP], any = 0;
    for (uint32_t l = 0; l < CODEC_GROUP; l++) base[l] = CODEC_T_ROOT * CODEC_NSYM;
    for (uint32_t v = 0; v < nv; v++) {
        uint32_t bits[CODEC_GROUP], nb[CODEC_GROUP], esc = 0;
        for (uint32_t l = 0; l < CODEC_GROUP; l++) {
            uint32_t c[3], f[3], mx = 0;
            for (uint32_t a = 0; a < 3; a++) {
                int32_t r = resid(t, v, a, l);
                c[a] = class_of(mag(r));
                f[a] = field(r, c[a] < CODEC_ESCAPE ? c[a] : 0);
                mx = c[a] > mx ? c[a] : mx;
            }
            esc |= (uint32_t)(mx == CODEC_ESCAPE) << l;
            t->sym[v * CODEC_GROUP + l] = (uint16_t)(base[l] + c[0] + CODEC_NCLASS * c[1] + CODEC_NCLASS * CODEC_NCLASS * c[2]);
            base[l] = v == 0 ? CODEC_T_FIRST * CODEC_NSYM : codec_body_table(c[0], c[1], c[2]) * CODEC_NSYM;
            nb[l] = c[0] + c[1] + c[2];
            bits[l] = f[0] | f[1] << c[0] | f[2] << (c[0] + c[1]);
        }
        for (uint32_t h = 0; h < 2u; h++) { /* lanes 4h .. 4h + 3, the vector path's order */
            uint64_t q = 0;
            uint32_t len = 0;
            for (uint32_t l = 4u * h; l < 4u * h + 4u; l++) {
                q |= (uint64_t)bits[l] << len;
                len += nb[l];
            }
            t->pbits[4u * v + h] = q;
            t->pbits[4u * v + 2u + h] = len;
        }
        t->esc[v] = (uint8_t)esc;
        any |= esc;
        if (esc || all)
            for (uint32_t a = 0; a < 3; a++)
                for (uint32_t l = 0; l < CODEC_GROUP; l++)
                    axis_bits(resid(t, v, a, l), t->xbits + (size_t)v * CODEC_XSTRIDE + 3u * CODEC_GROUP * a + l);
    }
    return any;
}

#ifdef __AVX2__
/* Classes (0..6) and raw fields (meaningless for class 6) of 8 residuals. */
static inline __m256i class8(__m256i r, __m256i *f)
{
    const __m256i one = _mm256_set1_epi32(1);
    __m256i m = _mm256_abs_epi32(r), m2 = _mm256_add_epi32(m, m);
    __m256i c = _mm256_sub_epi32(_mm256_srli_epi32(_mm256_castps_si256(_mm256_cvtepi32_ps(_mm256_or_si256(m2, one))), 23),
                                 _mm256_set1_epi32(127));
    c = _mm256_min_epi32(c, _mm256_set1_epi32((int32_t)CODEC_ESCAPE));
    /* below 2^c, 2 m has its leading one at bit c (m > 0): clearing it keeps the c bits */
    *f = _mm256_andnot_si256(_mm256_sllv_epi32(one, c), _mm256_or_si256(m2, _mm256_srli_epi32(r, 31)));
    return c;
}

/* axis_bits() of 8 residuals r (classes c, fields f of class8) into x[0..24). floor(log2 m)
 * from the float32 exponent of m, one less where rounding carried it past m. */
static inline void axis_bits8(__m256i r, __m256i c, __m256i f, uint32_t *x)
{
    const __m256i one = _mm256_set1_epi32(1), m = _mm256_abs_epi32(r);
    __m256i ex = _mm256_sub_epi32(_mm256_srli_epi32(_mm256_castps_si256(_mm256_cvtepi32_ps(m)), 23), _mm256_set1_epi32(127));
    ex = _mm256_add_epi32(ex, _mm256_cmpgt_epi32(_mm256_sllv_epi32(one, ex), m));
    const __m256i mant = _mm256_sub_epi32(m, _mm256_sllv_epi32(one, ex));
    const __m256i head = _mm256_or_si256(_mm256_sub_epi32(ex, _mm256_set1_epi32(5)),
                                         _mm256_slli_epi32(_mm256_srli_epi32(r, 31), CODEC_ESC_BITS));
    const __m256i e = _mm256_cmpeq_epi32(c, _mm256_set1_epi32((int32_t)CODEC_ESCAPE));
    const __m256i lo = _mm256_blendv_epi8(f, _mm256_or_si256(head, _mm256_slli_epi32(mant, CODEC_ESC_BITS + 1u)), e);
    const __m256i hi = _mm256_and_si256(_mm256_srli_epi32(mant, 32u - (CODEC_ESC_BITS + 1u)), e);
    const __m256i n = _mm256_blendv_epi8(c, _mm256_add_epi32(ex, _mm256_set1_epi32((int32_t)(CODEC_ESC_BITS + 1u))), e);
    _mm256_storeu_si256((__m256i *)(void *)x, lo);
    _mm256_storeu_si256((__m256i *)(void *)(x + CODEC_GROUP), hi);
    _mm256_storeu_si256((__m256i *)(void *)(x + 2u * CODEC_GROUP), n);
}

/* Selection masks of the lanes' modes. */
typedef struct modesel {
    __m256i is1, is2;
} modesel;

/* Residuals of axis a, vertex v (phase: 0 the root, 1 vertex 1, 2 later ones) of every lane. */
static inline __attribute__((always_inline)) __m256i resid8(const modesel *ms, const int32_t *cand, const int32_t *root,
                                                            uint32_t v, uint32_t a, int phase)
{
    if (phase == 0) return _mm256_loadu_si256((const __m256i *)(const void *)(root + a * CODEC_GROUP));
    const int32_t *c = cand + CODEC_CAT(v, a, 0, 0);
    if (phase == 1) return _mm256_loadu_si256((const __m256i *)(const void *)c);
    __m256i r0 = _mm256_loadu_si256((const __m256i *)(const void *)c),
            r1 = _mm256_loadu_si256((const __m256i *)(const void *)(c + CODEC_GROUP)),
            r2 = _mm256_loadu_si256((const __m256i *)(const void *)(c + 2u * CODEC_GROUP));
    return _mm256_blendv_epi8(_mm256_blendv_epi8(r0, r1, ms->is1), r2, ms->is2);
}

/* One vertex of all lanes: residuals stored, symbols (table from base, the next base
 * returned), each lane's raw bits and length, lanes 0-3 and 4-7 packed, the escape mask. */
static inline __attribute__((always_inline)) __m256i tok_vertex(__m256i base, const modesel *ms, uint32_t v, int phase,
                                                                const codec_tokens *t, uint32_t *any)
{
    __m256i c[3], f[3];
    for (uint32_t a = 0; a < 3; a++) c[a] = class8(resid8(ms, t->cand, t->root, v, a, phase), &f[a]);
    __m256i mx = _mm256_max_epi32(_mm256_max_epi32(c[0], c[1]), c[2]);
    uint32_t esc = (uint32_t)_mm256_movemask_ps(
        _mm256_castsi256_ps(_mm256_cmpeq_epi32(mx, _mm256_set1_epi32((int32_t)CODEC_ESCAPE))));
    t->esc[v] = (uint8_t)esc;
    *any |= esc;
    __m256i c12 = _mm256_add_epi32(c[1], _mm256_sub_epi32(_mm256_slli_epi32(c[2], 3), c[2])); /* c1 + 7 c2 */
    __m256i sym = _mm256_add_epi32(c[0], _mm256_sub_epi32(_mm256_slli_epi32(c12, 3), c12));
    __m256i idx = _mm256_add_epi32(base, sym);
    __m256i w = _mm256_permute4x64_epi64(_mm256_packus_epi32(idx, idx), 0x08);
    _mm_storeu_si128((__m128i *)(void *)(t->sym + (size_t)v * CODEC_GROUP), _mm256_castsi256_si128(w));
    __m256i nb = _mm256_add_epi32(_mm256_add_epi32(c[0], c[1]), c[2]);
    __m256i bits = _mm256_or_si256(_mm256_or_si256(f[0], _mm256_sllv_epi32(f[1], c[0])),
                                   _mm256_sllv_epi32(f[2], _mm256_add_epi32(c[0], c[1])));
    /* lane pairs: even | odd << nb(even), in 64-bit lanes (at most 30 bits) */
    const __m256i lo = _mm256_set1_epi64x(0xffffffff);
    __m256i nbe = _mm256_and_si256(nb, lo);
    __m256i pb = _mm256_or_si256(_mm256_and_si256(bits, lo), _mm256_sllv_epi64(_mm256_srli_epi64(bits, 32), nbe));
    __m256i pn = _mm256_add_epi32(nbe, _mm256_srli_epi64(nb, 32));
    /* pairs of pairs: lanes 0-3 and 4-7 (at most 60 bits), then their lengths */
    __m256i q = _mm256_or_si256(pb, _mm256_sllv_epi64(_mm256_permute4x64_epi64(pb, 0xf5), pn));
    __m256i len = _mm256_add_epi64(pn, _mm256_permute4x64_epi64(pn, 0xf5));
    __m256i out = _mm256_blend_epi32(_mm256_permute4x64_epi64(q, 0x08), _mm256_permute4x64_epi64(len, 0x80), 0xf0);
    _mm256_storeu_si256((__m256i *)(void *)(t->pbits + 4u * (size_t)v), out);
    if (phase == 0) return _mm256_set1_epi32((int32_t)(CODEC_T_FIRST * CODEC_NSYM));
    const __m256i body = _mm256_setr_epi32((int32_t)((CODEC_T_BODY + 0u) * CODEC_NSYM), (int32_t)((CODEC_T_BODY + 1u) * CODEC_NSYM),
                                           (int32_t)((CODEC_T_BODY + 2u) * CODEC_NSYM), (int32_t)((CODEC_T_BODY + 3u) * CODEC_NSYM),
                                           (int32_t)((CODEC_T_BODY + 4u) * CODEC_NSYM), (int32_t)((CODEC_T_BODY + 5u) * CODEC_NSYM),
                                           (int32_t)((CODEC_T_BODY + 5u) * CODEC_NSYM), (int32_t)((CODEC_T_BODY + 5u) * CODEC_NSYM));
    return _mm256_permutevar8x32_epi32(body, mx); /* the body table of classes up to 6 */
}

/* Vertex by vertex, all lanes at once; vertices 0 and 1 peeled (root, first segment). */
static uint32_t tokens_avx2(const codec_tokens *t, uint32_t nv, bool all)
{
    const __m256i k = _mm256_loadu_si256((const __m256i *)(const void *)t->mode);
    const modesel ms = { .is1 = _mm256_cmpeq_epi32(k, _mm256_set1_epi32(1)), .is2 = _mm256_cmpeq_epi32(k, _mm256_set1_epi32(2)) };
    uint32_t any = 0;
    __m256i base = _mm256_set1_epi32((int32_t)(CODEC_T_ROOT * CODEC_NSYM));
    base = tok_vertex(base, &ms, 0, 0, t, &any);
    base = tok_vertex(base, &ms, 1, 1, t, &any);
    for (uint32_t v = 2; v < nv; v++) base = tok_vertex(base, &ms, v, 2, t, &any);
    for (uint32_t v = 0; (any || all) && v < nv; v++) { /* the vertices that escape somewhere, again */
        if (!t->esc[v] && !all) continue;
        for (uint32_t a = 0; a < 3; a++) {
            __m256i f, r = resid8(&ms, t->cand, t->root, v, a, v < 2u ? (int)v : 2);
            __m256i c = class8(r, &f);
            axis_bits8(r, c, f, t->xbits + (size_t)v * CODEC_XSTRIDE + 3u * CODEC_GROUP * a);
        }
    }
    return any;
}
#endif

uint32_t codec_tokens_group(const codec_tokens *t, uint32_t nv, bool all, bool portable)
{
#ifdef __AVX2__
    if (!portable) return tokens_avx2(t, nv, all);
#endif
    (void)portable;
    return tokens_portable(t, nv, all);
}

/* The raw bits of lane l's vertex v axis by axis from codec_tokens.xbits. */
static inline void emit_axes(codec_emitter *e, const codec_tokens *t, uint32_t v, uint32_t l)
{
    const uint32_t *x = t->xbits + (size_t)v * CODEC_XSTRIDE + l;
    for (uint32_t a = 0; a < 3; a++, x += 3u * CODEC_GROUP)
        codec_emit_bits(e, x[0] | (uint64_t)x[CODEC_GROUP] << 32, x[2u * CODEC_GROUP]);
}

/* Four lanes' raw bits packed into q (len <= 60 bits). */
static inline void emit_packed(codec_emitter *e, uint64_t q, uint32_t len)
{
    if (len > 56u) { /* rare: 57 to 60 bits do not fit beside 7 pending ones */
        codec_emit_bits(e, q & 0xffffffffu, 32u);
        q >>= 32;
        len -= 32u;
    }
    codec_emit_bits(e, q, len);
}

/* A full group: the symbols copied (unless already in place), the histogram counted in four
 * copies (so repeated symbols do not wait on each other), the raw bits appended four lanes at a
 * time where none of the four escapes, else lane by lane (esc: a lane escapes somewhere). The
 * emitter is worked on in a local copy, kept in registers. */
static inline __attribute__((always_inline)) void emit_full(codec_emitter *ep, const codec_tokens *t, uint32_t nv,
                                                            const bool esc)
{
    codec_emitter e = *ep;
    const size_t n = (size_t)nv * CODEC_GROUP;
    uint16_t *out = e.syms + e.nsyms;
    if (out != t->sym) memcpy(out, t->sym, n * sizeof *out);
    e.nsyms += n;
    uint32_t *const h0 = e.counts, *const h1 = h0 + CODEC_HIST_SIZE, *const h2 = h1 + CODEC_HIST_SIZE,
                   *const h3 = h2 + CODEC_HIST_SIZE;
    for (size_t i = 0; i < n; i += 4u) {
        h0[out[i]]++;
        h1[out[i + 1u]]++;
        h2[out[i + 2u]]++;
        h3[out[i + 3u]]++;
    }
    for (uint32_t v = 0; v < nv; v++) {
        const uint64_t *pb = t->pbits + 4u * (size_t)v;
        const uint32_t ev = esc ? t->esc[v] : 0u;
        for (uint32_t k = 0; k < 2u; k++) {
            if (ev >> (4u * k) & 0xfu) { /* every axis of the four lanes on its own: no branch per lane */
                for (uint32_t l = 4u * k; l < 4u * k + 4u; l++) emit_axes(&e, t, v, l);
            } else
                emit_packed(&e, pb[k], (uint32_t)pb[2u + k]);
        }
    }
    *ep = e;
}

void codec_emit_group(codec_emitter *e, const codec_tokens *t, const uint32_t mode[CODEC_GROUP], uint32_t n,
                      uint32_t nv, uint32_t esc)
{
    for (uint32_t l = 0; l < n; l++) codec_emit_symbol(e, CODEC_T_MODE, mode[l]);
    if (n == CODEC_GROUP) {
        if (esc)
            emit_full(e, t, nv, true);
        else
            emit_full(e, t, nv, false);
        return;
    }
    for (uint32_t v = 0; v < nv; v++) { /* the last group's lanes 0 .. n - 1 */
        const uint16_t *sym = t->sym + (size_t)v * CODEC_GROUP;
        for (uint32_t l = 0; l < n; l++) {
            e->syms[e->nsyms++] = sym[l];
            e->counts[sym[l]]++;
        }
        for (uint32_t l = 0; l < n; l++) emit_axes(e, t, v, l);
    }
}

uint8_t *codec_emit_finish(codec_emitter *e)
{
    if (e->n) codec_emit_bits(e, 0, 8u - e->n);
    return e->bits;
}
