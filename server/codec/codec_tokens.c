/* codec: a strand's residuals into vertex symbols (magnitude classes), escape symbols and raw
 * bits, with the symbol histogram. */
#include "codec_simd.h"

static inline uint32_t mag(int32_t r)
{
    return r < 0 ? 0u - (uint32_t)r : (uint32_t)r;
}

/* One vertex (residuals r[0..3) coded in table t); returns the table of the next vertex. */
static uint32_t emit_vertex(codec_emitter *e, uint32_t t, const int32_t r[3])
{
    uint32_t c[3], esc[3], nesc = 0;
    for (uint32_t a = 0; a < 3; a++) {
        uint32_t m = mag(r[a]), sign = (uint32_t)r[a] >> 31;
        c[a] = codec_class(m);
        if (c[a] == 0) continue;
        if (c[a] < CODEC_ESCAPE) {
            /* sign, then the bits below the leading one */
            codec_emit_bits(e, ((m << 1) | sign) & ((1u << c[a]) - 1u), c[a]);
        } else {
            uint32_t ex = 31u - (uint32_t)__builtin_clz(m);
            esc[nesc++] = ex - 5u;
            codec_emit_bits(e, sign, 1);
            codec_emit_bits(e, m - (1u << ex), ex);
        }
    }
    codec_emit_symbol(e, t, c[0] + CODEC_NCLASS * c[1] + CODEC_NCLASS * CODEC_NCLASS * c[2]);
    for (uint32_t k = 0; k < nesc; k++) codec_emit_symbol(e, CODEC_T_ESC, esc[k]);
    return codec_body_table(c[0], c[1], c[2]);
}

static void emit_portable(codec_emitter *e, uint32_t kind, const int32_t *const P[3], const int32_t *const X[3],
                          const int32_t root[3], uint32_t nv, int32_t *const R[3])
{
    for (uint32_t a = 0; a < 3; a++) {
        R[a][0] = root[a];
        R[a][1] = (P[a][1] - P[a][0]) - (X[a][1] - X[a][0]);
        for (uint32_t v = 2; v < nv; v++) R[a][v] = codec_kind_one(kind, P[a], X[a], v);
    }
    uint32_t t = CODEC_T_ROOT;
    for (uint32_t v = 0; v < nv; v++) {
        const int32_t r[3] = { R[0][v], R[1][v], R[2][v] };
        t = emit_vertex(e, t, r);
        if (v == 0) t = CODEC_T_FIRST;
    }
}

#ifdef __AVX2__
/* Classes (0..6) and raw fields (sign, then the bits below the leading one; meaningless for
 * class 6) of 8 residuals. */
static inline __m256i class8(__m256i r, __m256i *field)
{
    const __m256i one = _mm256_set1_epi32(1);
    __m256i m = _mm256_abs_epi32(r);
    __m256i t = _mm256_or_si256(_mm256_add_epi32(m, m), one);
    __m256i c = _mm256_sub_epi32(_mm256_srli_epi32(_mm256_castps_si256(_mm256_cvtepi32_ps(t)), 23),
                                 _mm256_set1_epi32(127));
    c = _mm256_min_epi32(c, _mm256_set1_epi32((int32_t)CODEC_ESCAPE));
    __m256i f = _mm256_or_si256(_mm256_add_epi32(m, m), _mm256_srli_epi32(r, 31));
    *field = _mm256_and_si256(f, _mm256_sub_epi32(_mm256_sllv_epi32(one, c), one));
    return c;
}

/* Vertex v of a pair with an escape, one at a time: raw bits per axis as emit_vertex, its
 * symbol idx (the table already chosen), then any escape symbols. */
static void emit_indexed(codec_emitter *e, const int32_t *const R[3], uint32_t v, uint32_t idx)
{
    uint32_t esc[3], nesc = 0;
    for (uint32_t a = 0; a < 3; a++) {
        uint32_t m = mag(R[a][v]), sign = (uint32_t)R[a][v] >> 31, c = codec_class(m);
        if (c < CODEC_ESCAPE) {
            codec_emit_bits(e, ((m << 1) | sign) & ((1u << c) - 1u), c);
        } else {
            uint32_t ex = 31u - (uint32_t)__builtin_clz(m);
            esc[nesc++] = ex - 5u;
            codec_emit_bits(e, sign | (uint64_t)(m - (1u << ex)) << 1, ex + 1u);
        }
    }
    e->syms[e->nsyms++] = (uint16_t)idx;
    e->counts[idx]++;
    for (uint32_t k = 0; k < nesc; k++) codec_emit_symbol(e, CODEC_T_ESC, esc[k]);
}

/* Vector part: per vertex its symbol (table * CODEC_NSYM + classes) into s->idx, the raw bits
 * of vertex pairs into s->pair_bits / pair_nb (valid where no axis escapes), and per block of
 * 8 vertices a mask of the escaped ones into s->esc. Scalar part: the bit stream, the symbols
 * and the histogram, pair by pair; escaped vertices one at a time. */
static void tokens_avx2(codec_emitter *e, uint32_t kind, const int32_t *const P[3], const int32_t *const X[3],
                        const int32_t root[3], uint32_t nv, const codec_tok_scratch *s)
{
    const int32_t *const *R = (const int32_t *const *)s->R;
    const __m256i seven = _mm256_set1_epi32((int32_t)CODEC_NCLASS), five = _mm256_set1_epi32((int32_t)CODEC_NBODY - 1),
                  nsym = _mm256_set1_epi32((int32_t)CODEC_NSYM), rot = _mm256_setr_epi32(7, 0, 1, 2, 3, 4, 5, 6),
                  lo32 = _mm256_set1_epi64x(0xffffffffll);
    const __m256i body0 = _mm256_set1_epi32((int32_t)(CODEC_T_BODY * CODEC_NSYM));
    /* lane 0 of prev: the table base of the vertex before this block's first */
    __m256i prev = _mm256_set1_epi32((int32_t)(CODEC_T_ROOT * CODEC_NSYM));
    for (uint32_t v0 = 0; v0 < nv; v0 += CODEC_LANES) {
        __m256i r[3];
        for (uint32_t a = 0; a < 3; a++) {
            codec_seg8 sg = codec_segments8(P[a], X[a], v0);
            r[a] = codec_kind8(kind, &sg, v0);
            if (v0 == 0) /* the root, then vertex 1: dP - dX */
                r[a] = _mm256_blend_epi32(_mm256_blend_epi32(r[a], codec_kind0_8(&sg), 0x02),
                                          _mm256_set1_epi32(root[a]), 0x01);
            if (v0 + CODEC_LANES > nv) r[a] = _mm256_and_si256(r[a], codec_lanes8(v0, 0, nv));
            codec_st8(s->R[a] + v0, r[a]);
        }
        __m256i fx, fy, fz;
        __m256i cx = class8(r[0], &fx), cy = class8(r[1], &fy), cz = class8(r[2], &fz);
        __m256i mx = _mm256_max_epi32(_mm256_max_epi32(cx, cy), cz);
        s->esc[v0 / CODEC_LANES] = (uint8_t)_mm256_movemask_ps(
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(mx, _mm256_set1_epi32((int32_t)CODEC_ESCAPE))));
        __m256i sym = _mm256_add_epi32(cx, _mm256_mullo_epi32(seven, _mm256_add_epi32(cy, _mm256_mullo_epi32(seven, cz))));
        /* table base of the next vertex, shifted one lane up: this block's bases */
        __m256i next = _mm256_add_epi32(body0, _mm256_mullo_epi32(nsym, _mm256_min_epi32(mx, five)));
        __m256i nrot = _mm256_permutevar8x32_epi32(next, rot);
        __m256i base = _mm256_blend_epi32(nrot, prev, 0x01);
        if (v0 == 0) base = _mm256_blend_epi32(base, _mm256_set1_epi32((int32_t)(CODEC_T_FIRST * CODEC_NSYM)), 0x02);
        prev = nrot;
        __m256i idx = _mm256_add_epi32(base, sym);
        _mm_storeu_si128((__m128i *)(void *)(s->idx + v0),
                         _mm_packus_epi32(_mm256_castsi256_si128(idx), _mm256_extracti128_si256(idx, 1)));
        /* raw bits of each vertex: x field, then y, then z; then pairs of vertices in 64 bits */
        __m256i nb = _mm256_add_epi32(_mm256_add_epi32(cx, cy), cz);
        __m256i bits = _mm256_or_si256(_mm256_or_si256(fx, _mm256_sllv_epi32(fy, cx)),
                                       _mm256_sllv_epi32(fz, _mm256_add_epi32(cx, cy)));
        __m256i nlo = _mm256_and_si256(nb, lo32);
        __m256i pb = _mm256_or_si256(_mm256_and_si256(bits, lo32), _mm256_sllv_epi64(_mm256_srli_epi64(bits, 32), nlo));
        _mm256_storeu_si256((__m256i *)(void *)(s->pair_bits + v0 / 2u), pb);
        _mm256_storeu_si256((__m256i *)(void *)(s->pair_nb + v0 / 2u), _mm256_add_epi64(nlo, _mm256_srli_epi64(nb, 32)));
    }

    uint32_t *const h0 = e->counts, *const h1 = h0 + CODEC_HIST_SIZE, *const h2 = h1 + CODEC_HIST_SIZE,
                   *const h3 = h2 + CODEC_HIST_SIZE;
    uint8_t *p = e->bits;
    uint64_t acc = e->acc;
    uint32_t n = e->n;
    uint16_t *out = e->syms;
    size_t ns = e->nsyms;
    const uint16_t *idx = s->idx;
#define PAIR(k)                                \
    do {                                       \
        acc |= s->pair_bits[k] << n;           \
        n += (uint32_t)s->pair_nb[k];          \
        codec_put_le64(p, acc);                \
        p += n >> 3;                           \
        acc >>= n & ~7u;                       \
        n &= 7u;                               \
    } while (0)
    for (uint32_t v0 = 0; v0 < nv; v0 += CODEC_LANES) {
        const uint32_t esc = s->esc[v0 / CODEC_LANES], k0 = v0 / 2u;
        const uint16_t *b = idx + v0;
        if (__builtin_expect(esc == 0 && v0 + CODEC_LANES <= nv, 1)) {
            PAIR(k0);
            PAIR(k0 + 1u);
            PAIR(k0 + 2u);
            PAIR(k0 + 3u);
            memcpy(out + ns, b, CODEC_LANES * sizeof *out);
            ns += CODEC_LANES;
            h0[b[0]]++;
            h1[b[1]]++;
            h2[b[2]]++;
            h3[b[3]]++;
            h0[b[4]]++;
            h1[b[5]]++;
            h2[b[6]]++;
            h3[b[7]]++;
            continue;
        }
        for (uint32_t v = v0; v < v0 + CODEC_LANES && v < nv; v += 2u) {
            if (!(esc >> (v - v0) & 3u) && v + 1u < nv) {
                PAIR(v / 2u);
                out[ns++] = idx[v];
                out[ns++] = idx[v + 1u];
                h0[idx[v]]++;
                h1[idx[v + 1u]]++;
                continue;
            }
            e->bits = p;
            e->acc = acc;
            e->n = n;
            e->nsyms = ns;
            for (uint32_t w = v; w < v + 2u && w < nv; w++) emit_indexed(e, R, w, idx[w]);
            p = e->bits;
            acc = e->acc;
            n = e->n;
            ns = e->nsyms;
        }
    }
#undef PAIR
    e->bits = p;
    e->acc = acc;
    e->n = n;
    e->nsyms = ns;
}
#endif

void codec_emit_strand(codec_emitter *e, uint32_t kind, const int32_t *const P[3], const int32_t *const X[3],
                       const int32_t root[3], uint32_t nv, const codec_tok_scratch *s, bool portable)
{
#ifdef __AVX2__
    if (!portable) {
        tokens_avx2(e, kind, P, X, root, nv, s);
        return;
    }
#endif
    (void)portable;
    emit_portable(e, kind, P, X, root, nv, s->R);
}

uint8_t *codec_emit_finish(codec_emitter *e)
{
    if (e->n) codec_emit_bits(e, 0, 8u - e->n);
    return e->bits;
}
