/* core: allocation, copies, validation and strand tracing of core_hairmesh. */
#include "hairmesh_types.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

/* Guide counts within the limits: none, or nguides guides of 2 or more vertices each. */
static bool guides_fit(uint32_t nguides, uint32_t guide_nverts)
{
    if (nguides == 0) return true;
    return nguides <= CORE_HAIRMESH_MAX_GUIDES && guide_nverts >= 2 &&
           (uint64_t)nguides * guide_nverts <= CORE_HAIRMESH_MAX_GUIDE_VERTS;
}

core_status core_hairmesh_alloc(core_hairmesh *m, uint32_t ncols, uint32_t nlayers, uint32_t nfaces,
                                uint32_t nguides, uint32_t guide_nverts, core_err *err)
{
    memset(m, 0, sizeof *m);
    if (ncols < 3 || nlayers < 2 || nlayers > CORE_HAIRMESH_MAX_LAYERS || nfaces == 0 ||
        nfaces > CORE_HAIRMESH_MAX_FACES || !guides_fit(nguides, guide_nverts) ||
        (uint64_t)ncols * nlayers > CORE_HAIRMESH_MAX_VERTS)
        return core_fail(err, CORE_EINVAL,
                         "hair mesh of %u columns x %u layers, %u faces, %u guides of %u vertices is outside the limits "
                         "(>= 3 columns, 2..%u layers, 1..%u faces, <= %u vertices, <= %u guides of >= 2 vertices, "
                         "<= %u guide vertices)",
                         ncols, nlayers, nfaces, nguides, guide_nverts, CORE_HAIRMESH_MAX_LAYERS,
                         CORE_HAIRMESH_MAX_FACES, CORE_HAIRMESH_MAX_VERTS, CORE_HAIRMESH_MAX_GUIDES,
                         CORE_HAIRMESH_MAX_GUIDE_VERTS);
    m->pos = calloc((size_t)ncols * nlayers * 3, sizeof(float));
    m->faces = calloc((size_t)nfaces * 4, sizeof(uint32_t));
    if (nguides) {
        m->guide_face = calloc(nguides, sizeof(uint32_t));
        m->guide_uv = calloc((size_t)nguides * 2, sizeof(float));
        m->guide_t = calloc((size_t)nguides * guide_nverts, sizeof(float));
    }
    if (!m->pos || !m->faces || (nguides && (!m->guide_face || !m->guide_uv || !m->guide_t))) {
        core_hairmesh_free(m);
        return core_fail(err, CORE_ENOMEM, "out of memory for a hair mesh of %u x %u vertices", ncols, nlayers);
    }
    m->ncols = ncols;
    m->nlayers = nlayers;
    m->nfaces = nfaces;
    m->nguides = nguides;
    m->guide_nverts = nguides ? guide_nverts : 0;
    return CORE_OK;
}

void core_hairmesh_free(core_hairmesh *m)
{
    free(m->pos);
    free(m->faces);
    free(m->guide_face);
    free(m->guide_uv);
    free(m->guide_t);
    memset(m, 0, sizeof *m);
}

core_status core_hairmesh_copy(core_hairmesh *dst, const core_hairmesh *src, core_err *err)
{
    core_status st = core_hairmesh_alloc(dst, src->ncols, src->nlayers, src->nfaces, src->nguides, src->guide_nverts, err);
    if (st != CORE_OK) return st;
    memcpy(dst->pos, src->pos, (size_t)src->ncols * src->nlayers * 3 * sizeof(float));
    memcpy(dst->faces, src->faces, (size_t)src->nfaces * 4 * sizeof(uint32_t));
    if (src->nguides) {
        memcpy(dst->guide_face, src->guide_face, (size_t)src->nguides * sizeof(uint32_t));
        memcpy(dst->guide_uv, src->guide_uv, (size_t)src->nguides * 2 * sizeof(float));
        memcpy(dst->guide_t, src->guide_t, (size_t)src->nguides * src->guide_nverts * sizeof(float));
    }
    return CORE_OK;
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* Every layer edge is used by at most two faces. */
static core_status check_edges(const core_hairmesh *m, core_err *err)
{
    uint64_t *keys = malloc((size_t)m->nfaces * 4 * sizeof *keys);
    if (!keys) return core_fail(err, CORE_ENOMEM, "out of memory checking the hair mesh's edges");
    size_t n = 0;
    for (uint32_t f = 0; f < m->nfaces; f++) {
        const uint32_t *c = m->faces + 4 * (size_t)f;
        uint32_t nc = c[3] == CORE_HAIRMESH_NONE ? 3 : 4;
        for (uint32_t k = 0; k < nc; k++) {
            uint32_t a = c[k], b = c[(k + 1) % nc];
            keys[n++] = a < b ? ((uint64_t)a << 32) | b : ((uint64_t)b << 32) | a;
        }
    }
    qsort(keys, n, sizeof *keys, cmp_u64);
    core_status st = CORE_OK;
    for (size_t i = 2; i < n; i++)
        if (keys[i] == keys[i - 2]) {
            st = core_fail(err, CORE_EFORMAT, "hair mesh edge between columns %u and %u is shared by more than two faces",
                           (unsigned)(keys[i] >> 32), (unsigned)(keys[i] & 0xffffffffu));
            break;
        }
    free(keys);
    return st;
}

core_status core_hairmesh_validate(const core_hairmesh *m, core_err *err)
{
    if (m->ncols < 3 || m->nlayers < 2 || m->nlayers > CORE_HAIRMESH_MAX_LAYERS || m->nfaces == 0 ||
        m->nfaces > CORE_HAIRMESH_MAX_FACES || !guides_fit(m->nguides, m->guide_nverts) ||
        (uint64_t)m->ncols * m->nlayers > CORE_HAIRMESH_MAX_VERTS || !m->pos || !m->faces ||
        (m->nguides && (!m->guide_face || !m->guide_uv || !m->guide_t)))
        return core_fail(err, CORE_EFORMAT,
                         "hair mesh of %u columns x %u layers, %u faces, %u guides of %u vertices is outside the limits",
                         m->ncols, m->nlayers, m->nfaces, m->nguides, m->guide_nverts);
    size_t nv = (size_t)m->ncols * m->nlayers;
    for (size_t i = 0; i < 3 * nv; i++)
        if (!(fabsf(m->pos[i]) <= CORE_HAIRMESH_MAX_COORD))
            return core_fail(err, CORE_EFORMAT, "hair mesh column %zu layer %zu: coordinate %g is not finite or beyond %g m",
                             i / 3 / m->nlayers, i / 3 % m->nlayers, (double)m->pos[i], (double)CORE_HAIRMESH_MAX_COORD);
    uint8_t *used = calloc(m->ncols, 1);
    if (!used) return core_fail(err, CORE_ENOMEM, "out of memory checking a hair mesh");
    core_status st = CORE_OK;
    for (uint32_t f = 0; f < m->nfaces && st == CORE_OK; f++) {
        const uint32_t *c = m->faces + 4 * (size_t)f;
        uint32_t nc = c[3] == CORE_HAIRMESH_NONE ? 3 : 4;
        for (uint32_t k = 0; k < nc && st == CORE_OK; k++) {
            if (c[k] >= m->ncols)
                st = core_fail(err, CORE_EFORMAT, "hair mesh face %u: column %u out of range (%u columns)", f, c[k], m->ncols);
            for (uint32_t j = 0; j < k && st == CORE_OK; j++)
                if (c[j] == c[k]) st = core_fail(err, CORE_EFORMAT, "hair mesh face %u uses column %u twice", f, c[k]);
        }
        for (uint32_t k = 0; k < nc && st == CORE_OK; k++) used[c[k]] = 1;
    }
    for (uint32_t c = 0; c < m->ncols && st == CORE_OK; c++)
        if (!used[c]) st = core_fail(err, CORE_EFORMAT, "hair mesh column %u is used by no face", c);
    free(used);
    if (st != CORE_OK) return st;
    st = check_edges(m, err);
    if (st != CORE_OK) return st;
    const float slack = 1e-5f;
    for (uint32_t s = 0; s < m->nguides; s++) {
        uint32_t f = m->guide_face[s];
        float u = m->guide_uv[2 * s], v = m->guide_uv[2 * s + 1];
        if (f >= m->nfaces) return core_fail(err, CORE_EFORMAT, "hair mesh guide %u: face %u out of range", s, f);
        bool tri = m->faces[4 * (size_t)f + 3] == CORE_HAIRMESH_NONE;
        bool in = tri ? (u >= -slack && v >= -slack && u + v <= 1.0f + slack)
                      : (u >= -slack && u <= 1.0f + slack && v >= -slack && v <= 1.0f + slack);
        if (!in) return core_fail(err, CORE_EFORMAT, "hair mesh guide %u: (%g, %g) is not inside face %u", s, (double)u, (double)v, f);
        const float *t = m->guide_t + (size_t)s * m->guide_nverts, top = (float)(m->nlayers - 1);
        for (uint32_t i = 0; i < m->guide_nverts; i++)
            if (!(t[i] >= (i ? t[i - 1] : 0.0f) && t[i] <= top))
                return core_fail(err, CORE_EFORMAT,
                                 "hair mesh guide %u: layer parameter %u (%g) is not in [%g, %g] (non-decreasing, "
                                 "at most the tip layer)", s, i, (double)t[i], i ? (double)t[i - 1] : 0.0, (double)top);
    }
    return CORE_OK;
}

void core_hairmesh_weights(uint32_t ncorners, float u, float v, float w[4])
{
    if (ncorners == 3) {
        w[0] = 1.0f - u - v, w[1] = u, w[2] = v, w[3] = 0.0f;
    } else {
        w[0] = (1.0f - u) * (1.0f - v), w[1] = u * (1.0f - v), w[2] = u * v, w[3] = (1.0f - u) * v;
    }
}

/* The guide point of face corners c (nc of them, weights w) at layer l. */
static void layer_point(const float *pos, uint32_t nlayers, const uint32_t *c, uint32_t nc, const float w[4],
                        uint32_t l, float out[3])
{
    out[0] = out[1] = out[2] = 0.0f;
    for (uint32_t k = 0; k < nc; k++) {
        const float *p = pos + 3 * ((size_t)c[k] * nlayers + l);
        out[0] += w[k] * p[0], out[1] += w[k] * p[1], out[2] += w[k] * p[2];
    }
}

/* A strand's rest polyline: the guide points of one face at one (u, v) through the layers. */
typedef struct strand_curve {
    const float *pos;
    uint32_t nlayers, nc;
    const uint32_t *c;
    double w[4];
} strand_curve;

/* The straight distance between a and b. */
static double dist3(const double a[3], const double b[3])
{
    return sqrt((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) + (b[2] - a[2]) * (b[2] - a[2]));
}

/* The guide point of curve k at layer l, in double. */
static void curve_point(const strand_curve *k, uint32_t l, double out[3])
{
    out[0] = out[1] = out[2] = 0.0;
    for (uint32_t j = 0; j < k->nc; j++) {
        const float *p = k->pos + 3 * ((size_t)k->c[j] * k->nlayers + l);
        out[0] += k->w[j] * (double)p[0], out[1] += k->w[j] * (double)p[1], out[2] += k->w[j] * (double)p[2];
    }
}

/* Walks the curve in nverts - 1 straight steps of length d from the root (the even-parameter
 * rule of hairmesh_types.h), writing the parameters of vertices 1.. into t when t is not NULL.
 * False when a step runs past the tip layer (d is too long). */
static bool walk(const strand_curve *k, uint32_t nverts, double d, float *t)
{
    double p[3], a_pt[3], b_pt[3];
    curve_point(k, 0, p);
    uint32_t l = 0;
    double a0 = 0.0; /* the parameter within segment l where the walk stands */
    curve_point(k, 0, a_pt);
    curve_point(k, 1, b_pt);
    for (uint32_t i = 1; i < nverts; i++) {
        for (;;) {
            double e[3] = { b_pt[0] - a_pt[0], b_pt[1] - a_pt[1], b_pt[2] - a_pt[2] };
            double g[3] = { a_pt[0] - p[0], a_pt[1] - p[1], a_pt[2] - p[2] };
            double qa = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
            double qb = 2.0 * (e[0] * g[0] + e[1] * g[1] + e[2] * g[2]);
            double qc = g[0] * g[0] + g[1] * g[1] + g[2] * g[2] - d * d;
            if (qa > 0.0) {
                /* the larger root of |A + a E - p|^2 = d^2 (|A + a0 E - p| < d, so it is past a0) */
                double disc = sqrt(fmax(qb * qb - 4.0 * qa * qc, 0.0));
                double a = qb >= 0.0 ? (qc < 0.0 ? 2.0 * qc / (-qb - disc) : 0.0) : (-qb + disc) / (2.0 * qa);
                if (a <= 1.0) {
                    a0 = fmax(a, a0);
                    break;
                }
            }
            if (l + 2 >= k->nlayers) return false;
            l++, a0 = 0.0;
            memcpy(a_pt, b_pt, sizeof a_pt);
            curve_point(k, l + 1, b_pt);
        }
        for (int j = 0; j < 3; j++) p[j] = a_pt[j] + a0 * (b_pt[j] - a_pt[j]);
        if (t) t[i] = (float)((double)l + a0);
    }
    return true;
}

/* The curve's point at layer parameter t (double; the rule's l and a). */
static void curve_at(const strand_curve *k, double t, double out[3])
{
    uint32_t l = (uint32_t)floor(t);
    if (l > k->nlayers - 2) l = k->nlayers - 2;
    double a = t - (double)l, p0[3], p1[3];
    curve_point(k, l, p0);
    curve_point(k, l + 1, p1);
    for (int j = 0; j < 3; j++) out[j] = p0[j] + a * (p1[j] - p0[j]);
}

/* The straight distance from vertex nverts - 2 (at t[nverts - 2]) to the tip-layer point. */
static double last_step(const strand_curve *k, uint32_t nverts, const float *t)
{
    double a[3], b[3];
    curve_at(k, nverts > 2 ? (double)t[nverts - 2] : 0.0, a);
    curve_point(k, k->nlayers - 1, b);
    return dist3(a, b);
}

/* The parameters of vertices 1 .. nverts - 2 at even arc length along the polyline of length len
 * (the fallback of the rule when no even straight distance exists). */
static void arc_params(const strand_curve *k, uint32_t nverts, double len, float *t)
{
    double a_pt[3], b_pt[3], s0 = 0.0, seg;
    uint32_t l = 0;
    curve_point(k, 0, a_pt);
    curve_point(k, 1, b_pt);
    seg = dist3(a_pt, b_pt);
    for (uint32_t i = 1; i + 1 < nverts; i++) {
        double want = (double)i * len / (double)(nverts - 1);
        while (s0 + seg < want && l + 2 < k->nlayers) {
            s0 += seg, l++;
            memcpy(a_pt, b_pt, sizeof a_pt);
            curve_point(k, l + 1, b_pt);
            seg = dist3(a_pt, b_pt);
        }
        t[i] = (float)((double)l + (seg > 0.0 ? fmin((want - s0) / seg, 1.0) : 0.0));
    }
}

void core_hairmesh_even_params(const core_hairmesh *m, const float *pos, uint32_t face, float u, float v,
                               uint32_t nverts, float *t)
{
    strand_curve k = { .pos = pos, .nlayers = m->nlayers, .c = m->faces + 4 * (size_t)face };
    k.nc = k.c[3] == CORE_HAIRMESH_NONE ? 3 : 4;
    float w[4];
    core_hairmesh_weights(k.nc, u, v, w);
    for (int j = 0; j < 4; j++) k.w[j] = (double)w[j];
    double len = 0.0, a_pt[3], b_pt[3];
    curve_point(&k, 0, a_pt);
    for (uint32_t l = 1; l < m->nlayers; l++, memcpy(a_pt, b_pt, sizeof a_pt)) {
        curve_point(&k, l, b_pt);
        len += dist3(a_pt, b_pt);
    }
    const float top = (float)(m->nlayers - 1);
    if (!(len > 0.0)) {
        for (uint32_t i = 0; i < nverts; i++) t[i] = (float)i * top / (float)(nverts - 1);
        return;
    }
    double lo = 0.0, hi = len / (double)(nverts - 1);
    for (int it = 0; it < 64; it++) {
        double mid = 0.5 * (lo + hi);
        if (walk(&k, nverts, mid, NULL)) lo = mid;
        else hi = mid;
    }
    double last = walk(&k, nverts, lo, t) ? last_step(&k, nverts, t) : -1.0;
    if (!(fabs(last - lo) <= 1e-4 * lo)) arc_params(&k, nverts, len, t);
    t[0] = 0.0f;
    t[nverts - 1] = top;
    for (uint32_t i = 1; i + 1 < nverts; i++) t[i] = fminf(t[i], top);
}

void core_hairmesh_trace(const core_hairmesh *m, const float *pos, uint32_t face, float u, float v,
                         uint32_t nverts, const float *t, float *out)
{
    const uint32_t *c = m->faces + 4 * (size_t)face;
    uint32_t nc = c[3] == CORE_HAIRMESH_NONE ? 3 : 4;
    float w[4];
    core_hairmesh_weights(nc, u, v, w);
    float a_pt[3] = { 0.0f, 0.0f, 0.0f }, b_pt[3] = { 0.0f, 0.0f, 0.0f };
    uint32_t have = CORE_HAIRMESH_NONE;
    for (uint32_t i = 0; i < nverts; i++) {
        uint32_t l = (uint32_t)floorf(t[i]);
        if (l > m->nlayers - 2) l = m->nlayers - 2;
        float a = t[i] - (float)l;
        if (have != l) {
            layer_point(pos, m->nlayers, c, nc, w, l, a_pt);
            layer_point(pos, m->nlayers, c, nc, w, l + 1, b_pt);
            have = l;
        }
        float *o = out + 3 * (size_t)i;
        o[0] = a_pt[0] + a * (b_pt[0] - a_pt[0]);
        o[1] = a_pt[1] + a * (b_pt[1] - a_pt[1]);
        o[2] = a_pt[2] + a * (b_pt[2] - a_pt[2]);
    }
}
