/* core: allocation, copies, validation and strand tracing of core_hairmesh. */
#include "hairmesh_types.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

core_status core_hairmesh_alloc(core_hairmesh *m, uint32_t ncols, uint32_t nlayers, uint32_t nfaces,
                                uint32_t nguides, core_err *err)
{
    memset(m, 0, sizeof *m);
    if (ncols < 3 || nlayers < 2 || nlayers > CORE_HAIRMESH_MAX_LAYERS || nfaces == 0 ||
        nfaces > CORE_HAIRMESH_MAX_FACES || nguides > CORE_HAIRMESH_MAX_GUIDES ||
        (uint64_t)ncols * nlayers > CORE_HAIRMESH_MAX_VERTS)
        return core_fail(err, CORE_EINVAL,
                         "hair mesh of %u columns x %u layers, %u faces, %u guides is outside the limits "
                         "(>= 3 columns, 2..%u layers, 1..%u faces, <= %u vertices, <= %u guides)",
                         ncols, nlayers, nfaces, nguides, CORE_HAIRMESH_MAX_LAYERS, CORE_HAIRMESH_MAX_FACES,
                         CORE_HAIRMESH_MAX_VERTS, CORE_HAIRMESH_MAX_GUIDES);
    m->pos = calloc((size_t)ncols * nlayers * 3, sizeof(float));
    m->faces = calloc((size_t)nfaces * 4, sizeof(uint32_t));
    if (nguides) {
        m->guide_face = calloc(nguides, sizeof(uint32_t));
        m->guide_uv = calloc((size_t)nguides * 2, sizeof(float));
    }
    if (!m->pos || !m->faces || (nguides && (!m->guide_face || !m->guide_uv))) {
        core_hairmesh_free(m);
        return core_fail(err, CORE_ENOMEM, "out of memory for a hair mesh of %u x %u vertices", ncols, nlayers);
    }
    m->ncols = ncols;
    m->nlayers = nlayers;
    m->nfaces = nfaces;
    m->nguides = nguides;
    return CORE_OK;
}

void core_hairmesh_free(core_hairmesh *m)
{
    free(m->pos);
    free(m->faces);
    free(m->guide_face);
    free(m->guide_uv);
    memset(m, 0, sizeof *m);
}

core_status core_hairmesh_copy(core_hairmesh *dst, const core_hairmesh *src, core_err *err)
{
    core_status st = core_hairmesh_alloc(dst, src->ncols, src->nlayers, src->nfaces, src->nguides, err);
    if (st != CORE_OK) return st;
    memcpy(dst->pos, src->pos, (size_t)src->ncols * src->nlayers * 3 * sizeof(float));
    memcpy(dst->faces, src->faces, (size_t)src->nfaces * 4 * sizeof(uint32_t));
    if (src->nguides) {
        memcpy(dst->guide_face, src->guide_face, (size_t)src->nguides * sizeof(uint32_t));
        memcpy(dst->guide_uv, src->guide_uv, (size_t)src->nguides * 2 * sizeof(float));
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
        m->nfaces > CORE_HAIRMESH_MAX_FACES || m->nguides > CORE_HAIRMESH_MAX_GUIDES ||
        (uint64_t)m->ncols * m->nlayers > CORE_HAIRMESH_MAX_VERTS || !m->pos || !m->faces ||
        (m->nguides && (!m->guide_face || !m->guide_uv)))
        return core_fail(err, CORE_EFORMAT, "hair mesh of %u columns x %u layers, %u faces, %u guides is outside the limits",
                         m->ncols, m->nlayers, m->nfaces, m->nguides);
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

void core_hairmesh_trace(const core_hairmesh *m, const float *pos, uint32_t face, float u, float v,
                         uint32_t nverts, float *out)
{
    const uint32_t *c = m->faces + 4 * (size_t)face;
    uint32_t nc = c[3] == CORE_HAIRMESH_NONE ? 3 : 4;
    float w[4];
    core_hairmesh_weights(nc, u, v, w);
    float a_pt[3] = { 0.0f, 0.0f, 0.0f }, b_pt[3] = { 0.0f, 0.0f, 0.0f };
    uint32_t have = CORE_HAIRMESH_NONE;
    for (uint32_t i = 0; i < nverts; i++) {
        float t = (float)i * (float)(m->nlayers - 1) / (float)(nverts - 1);
        uint32_t l = (uint32_t)floorf(t);
        if (l > m->nlayers - 2) l = m->nlayers - 2;
        float a = t - (float)l;
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
