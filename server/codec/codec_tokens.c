/* codec: a group's residuals into vertex symbols (magnitude classes) and raw bits, and their
 * emission strand by strand with escapes and the symbol histogram. */
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

/* The vector path's loop with the 8 lanes as an inner loop. */
static void tokens_portable(const uint32_t kind[CODEC_GROUP], const int32_t *cand, const int32_t root[3 * CODEC_GROUP],
                            uint32_t nv, const codec_tokens *t)
{
    uint32_t base[CODEC_GROUP], pb[CODEC_GROUP], pn[CODEC_GROUP], pi[CODEC_GROUP], esc[CODEC_GROUP];
    for (uint32_t l = 0; l < CODEC_GROUP; l++) base[l] = CODEC_T_ROOT * CODEC_NSYM;
    for (uint32_t v = 0; v < nv; v++) {
        if (v % 32u == 0)
            for (uint32_t l = 0; l < CODEC_GROUP; l++) esc[l] = 0;
        for (uint32_t l = 0; l < CODEC_GROUP; l++) {
            uint32_t c[3], f[3], mx = 0;
            for (uint32_t a = 0; a < 3; a++) {
                int32_t r = v ? cand[CODEC_CAT(v, a, kind[l], l)] : root[a * CODEC_GROUP + l];
                t->R[CODEC_GAT(v, a, l)] = r;
                c[a] = class_of(mag(r));
                f[a] = field(r, c[a] < CODEC_ESCAPE ? c[a] : 0);
                mx = c[a] > mx ? c[a] : mx;
            }
            esc[l] |= (uint32_t)(mx == CODEC_ESCAPE) << (v % 32u);
            uint32_t idx = base[l] + c[0] + CODEC_NCLASS * c[1] + CODEC_NCLASS * CODEC_NCLASS * c[2];
            base[l] = v == 0 ? CODEC_T_FIRST * CODEC_NSYM : codec_body_table(c[0], c[1], c[2]) * CODEC_NSYM;
            uint32_t nb = c[0] + c[1] + c[2], bits = f[0] | f[1] << c[0] | f[2] << (c[0] + c[1]);
            if (v % 2u == 0) {
                pb[l] = bits;
                pn[l] = nb;
                pi[l] = idx;
            } else {
                pb[l] |= bits << pn[l];
                pn[l] += nb;
                pi[l] |= idx << 16;
            }
        }
        if (v % 2u == 1u || v + 1u == nv)
            for (uint32_t l = 0; l < CODEC_GROUP; l++) {
                t->pbits[(v / 2u) * CODEC_GROUP + l] = pb[l];
                t->pnb[(v / 2u) * CODEC_GROUP + l] = pn[l];
                t->pidx[(v / 2u) * CODEC_GROUP + l] = pi[l];
            }
        if (v % 32u == 31u || v + 1u == nv)
            for (uint32_t l = 0; l < CODEC_GROUP; l++) t->esc[(v / 32u) * CODEC_GROUP + l] = esc[l];
    }
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
    *f = _mm256_and_si256(_mm256_or_si256(m2, _mm256_srli_epi32(r, 31)), _mm256_sub_epi32(_mm256_sllv_epi32(one, c), one));
    return c;
}

/* Selection masks of the lanes' kinds. */
typedef struct kindsel {
    __m256i is1, is3, hi;
} kindsel;

/* Residuals of axis a, vertex v (phase: 0 the root, 1 vertex 1, 2 later ones) of every lane. */
static inline __attribute__((always_inline)) __m256i resid8(const kindsel *ks, const int32_t *cand, const int32_t *root,
                                                            uint32_t v, uint32_t a, int phase)
{
    if (phase == 0) return _mm256_loadu_si256((const __m256i *)(const void *)(root + a * CODEC_GROUP));
    const int32_t *c = cand + CODEC_CAT(v, a, 0, 0);
    if (phase == 1) return _mm256_loadu_si256((const __m256i *)(const void *)c);
    __m256i r0 = _mm256_loadu_si256((const __m256i *)(const void *)c),
            r1 = _mm256_loadu_si256((const __m256i *)(const void *)(c + CODEC_GROUP)),
            r2 = _mm256_loadu_si256((const __m256i *)(const void *)(c + 2u * CODEC_GROUP)),
            r3 = _mm256_loadu_si256((const __m256i *)(const void *)(c + 3u * CODEC_GROUP));
    return _mm256_blendv_epi8(_mm256_blendv_epi8(r0, r1, ks->is1), _mm256_blendv_epi8(r2, r3, ks->is3), ks->hi);
}

/* State carried from vertex to vertex. */
typedef struct tokstate {
    __m256i base;       /* table base (table * CODEC_NSYM) of this vertex */
    __m256i pbits, pnb, pidx; /* the even vertex of the current pair */
    __m256i esc;        /* escape bits of the current 32 vertices */
} tokstate;

static inline __attribute__((always_inline)) void tok_vertex(tokstate *st, const kindsel *ks, const int32_t *cand,
                                                             const int32_t *root, uint32_t v, int phase,
                                                             const codec_tokens *t)
{
    __m256i r[3], c[3], f[3];
    for (uint32_t a = 0; a < 3; a++) {
        r[a] = resid8(ks, cand, root, v, a, phase);
        codec_stg(t->R, v, a, r[a]);
        c[a] = class8(r[a], &f[a]);
    }
    const __m256i seven = _mm256_set1_epi32((int32_t)CODEC_NCLASS);
    __m256i mx = _mm256_max_epi32(_mm256_max_epi32(c[0], c[1]), c[2]);
    __m256i esc = _mm256_cmpeq_epi32(mx, _mm256_set1_epi32((int32_t)CODEC_ESCAPE));
    st->esc = _mm256_or_si256(st->esc, _mm256_and_si256(esc, _mm256_set1_epi32((int32_t)(1u << (v % 32u)))));
    if (v % 32u == 31u) {
        _mm256_storeu_si256((__m256i *)(void *)(t->esc + (v / 32u) * CODEC_GROUP), st->esc);
        st->esc = _mm256_setzero_si256();
    }
    __m256i sym = _mm256_add_epi32(c[0], _mm256_mullo_epi32(seven, _mm256_add_epi32(c[1], _mm256_mullo_epi32(seven, c[2]))));
    const __m256i idx = _mm256_add_epi32(st->base, sym);
    st->base = phase == 0 ? _mm256_set1_epi32((int32_t)(CODEC_T_FIRST * CODEC_NSYM))
                          : _mm256_add_epi32(_mm256_set1_epi32((int32_t)(CODEC_T_BODY * CODEC_NSYM)),
                                             _mm256_mullo_epi32(_mm256_set1_epi32((int32_t)CODEC_NSYM),
                                                                _mm256_min_epi32(mx, _mm256_set1_epi32((int32_t)CODEC_NBODY - 1))));
    __m256i nb = _mm256_add_epi32(_mm256_add_epi32(c[0], c[1]), c[2]);
    __m256i bits = _mm256_or_si256(_mm256_or_si256(f[0], _mm256_sllv_epi32(f[1], c[0])),
                                   _mm256_sllv_epi32(f[2], _mm256_add_epi32(c[0], c[1])));
    if (v % 2u == 0) {
        st->pbits = bits;
        st->pnb = nb;
        st->pidx = idx;
    } else {
        _mm256_storeu_si256((__m256i *)(void *)(t->pidx + (v / 2u) * CODEC_GROUP),
                            _mm256_or_si256(st->pidx, _mm256_slli_epi32(idx, 16)));
        _mm256_storeu_si256((__m256i *)(void *)(t->pbits + (v / 2u) * CODEC_GROUP),
                            _mm256_or_si256(st->pbits, _mm256_sllv_epi32(bits, st->pnb)));
        _mm256_storeu_si256((__m256i *)(void *)(t->pnb + (v / 2u) * CODEC_GROUP), _mm256_add_epi32(st->pnb, nb));
    }
}

/* Vertex by vertex, all lanes at once; vertices 0 and 1 peeled (root, first segment). */
static void tokens_avx2(const uint32_t kind[CODEC_GROUP], const int32_t *cand, const int32_t root[3 * CODEC_GROUP],
                        uint32_t nv, const codec_tokens *t)
{
    const __m256i k = _mm256_loadu_si256((const __m256i *)(const void *)kind);
    const kindsel ks = { .is1 = _mm256_cmpeq_epi32(k, _mm256_set1_epi32(1)), .is3 = _mm256_cmpeq_epi32(k, _mm256_set1_epi32(3)),
                         .hi = _mm256_cmpgt_epi32(k, _mm256_set1_epi32(1)) };
    tokstate st = { .base = _mm256_set1_epi32((int32_t)(CODEC_T_ROOT * CODEC_NSYM)), .pbits = _mm256_setzero_si256(),
                    .pnb = _mm256_setzero_si256(), .pidx = _mm256_setzero_si256(), .esc = _mm256_setzero_si256() };
    tok_vertex(&st, &ks, cand, root, 0, 0, t);
    tok_vertex(&st, &ks, cand, root, 1, 1, t);
    for (uint32_t v = 2; v < nv; v++) tok_vertex(&st, &ks, cand, root, v, 2, t);
    if (nv % 2u) { /* the last vertex pairs with nothing */
        _mm256_storeu_si256((__m256i *)(void *)(t->pbits + (nv / 2u) * CODEC_GROUP), st.pbits);
        _mm256_storeu_si256((__m256i *)(void *)(t->pnb + (nv / 2u) * CODEC_GROUP), st.pnb);
        _mm256_storeu_si256((__m256i *)(void *)(t->pidx + (nv / 2u) * CODEC_GROUP), st.pidx);
    }
    if (nv % 32u) _mm256_storeu_si256((__m256i *)(void *)(t->esc + (nv / 32u) * CODEC_GROUP), st.esc);
}
#endif

void codec_tokens_group(const uint32_t kind[CODEC_GROUP], const int32_t *cand, const int32_t root[3 * CODEC_GROUP],
                        uint32_t nv, const codec_tokens *t, bool portable)
{
#ifdef __AVX2__
    if (!portable) {
        tokens_avx2(kind, cand, root, nv, t);
        return;
    }
#endif
    (void)portable;
    tokens_portable(kind, cand, root, nv, t);
}

/* Vertex v of lane l one axis at a time: raw bits per axis, its symbol (table already chosen),
 * then an escape symbol per escaped axis. */
static void emit_vertex(codec_emitter *e, const codec_tokens *t, uint32_t v, uint32_t l)
{
    uint32_t esc[3], nesc = 0;
    for (uint32_t a = 0; a < 3; a++) {
        int32_t r = t->R[CODEC_GAT(v, a, l)];
        uint32_t m = mag(r), c = codec_class(m);
        if (c < CODEC_ESCAPE) {
            codec_emit_bits(e, field(r, c), c);
        } else {
            uint32_t ex = 31u - (uint32_t)__builtin_clz(m);
            esc[nesc++] = ex - 5u;
            codec_emit_bits(e, ((uint32_t)r >> 31) | (uint64_t)(m - (1u << ex)) << 1, ex + 1u);
        }
    }
    uint32_t idx = t->pidx[(v / 2u) * CODEC_GROUP + l] >> (16u * (v & 1u)) & 0xffffu;
    e->syms[e->nsyms++] = (uint16_t)idx;
    e->counts[idx]++;
    for (uint32_t k = 0; k < nesc; k++) codec_emit_symbol(e, CODEC_T_ESC, esc[k]);
}

/* Lane l without escapes: pair by pair, the raw bits appended and the two symbols stored and
 * counted (histogram copies alternating, so that repeated symbols do not wait on each other). */
static void emit_lane_fast(codec_emitter *e, const codec_tokens *t, uint32_t l, uint32_t nv)
{
    uint32_t *const h0 = e->counts, *const h1 = h0 + CODEC_HIST_SIZE, *const h2 = h1 + CODEC_HIST_SIZE,
                   *const h3 = h2 + CODEC_HIST_SIZE;
    const uint32_t *pidx = t->pidx + l, *pbits = t->pbits + l, *pnb = t->pnb + l;
    uint8_t *p = e->bits;
    uint64_t acc = e->acc;
    uint32_t n = e->n;
    uint16_t *out = e->syms + e->nsyms;
    const uint32_t npairs = nv / 2u;
    uint32_t k = 0;
#define BITS()                                        \
    do {                                              \
        acc |= (uint64_t)pbits[k * CODEC_GROUP] << n; \
        n += pnb[k * CODEC_GROUP];                    \
        codec_put_le64(p, acc);                       \
        p += n >> 3;                                  \
        acc >>= n & ~7u;                              \
        n &= 7u;                                      \
    } while (0)
#define PAIR(H0, H1)                                  \
    do {                                              \
        BITS();                                       \
        uint32_t w = pidx[k * CODEC_GROUP];           \
        out[2u * k] = (uint16_t)w;                    \
        out[2u * k + 1u] = (uint16_t)(w >> 16);       \
        H0[w & 0xffffu]++;                            \
        H1[w >> 16]++;                                \
        k++;                                          \
    } while (0)
    for (; k + 2u <= npairs;) {
        PAIR(h0, h1);
        PAIR(h2, h3);
    }
    if (k < npairs) PAIR(h0, h1);
    if (nv % 2u) { /* the last vertex alone */
        BITS();
        uint32_t i0 = pidx[k * CODEC_GROUP];
        out[nv - 1u] = (uint16_t)i0;
        h2[i0]++;
    }
#undef PAIR
#undef BITS
    e->bits = p;
    e->acc = acc;
    e->n = n;
    e->nsyms += nv;
}

void codec_emit_lane(codec_emitter *e, const codec_tokens *t, uint32_t l, uint32_t nv)
{
    uint32_t any = 0;
    for (uint32_t c = 0; c < (nv + 31u) / 32u; c++) any |= t->esc[c * CODEC_GROUP + l];
    if (!any) {
        emit_lane_fast(e, t, l, nv);
        return;
    }
    for (uint32_t v = 0; v < nv; v += 2u) {
        const uint32_t esc = t->esc[(v / 32u) * CODEC_GROUP + l] >> (v % 32u) & 3u, k = v / 2u;
        if (esc || v + 1u == nv) {
            emit_vertex(e, t, v, l);
            if (v + 1u < nv) emit_vertex(e, t, v + 1u, l);
            continue;
        }
        codec_emit_bits(e, t->pbits[k * CODEC_GROUP + l], t->pnb[k * CODEC_GROUP + l]);
        for (uint32_t w = t->pidx[k * CODEC_GROUP + l], h = 0; h < 2; h++, w >>= 16) {
            e->syms[e->nsyms++] = (uint16_t)w;
            e->counts[w & 0xffffu]++;
        }
    }
}

uint8_t *codec_emit_finish(codec_emitter *e)
{
    if (e->n) codec_emit_bits(e, 0, 8u - e->n);
    return e->bits;
}
