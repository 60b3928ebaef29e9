/* tests: collision mesh loaders (.obj, .tfxmesh; valid, broken, truncated, fuzzed), signed
 * distance grids (sphere, box, Ratboy), core_sdf_sample and core_groom ownership of both. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "groom/groom.h"

/* ---- helpers ------------------------------------------------------------------------- */

static uint64_t rng_state = 0x1234567;
static double rnd(void) /* [0, 1) */
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}

typedef struct text {
    char *s;
    size_t n, cap;
} text;

static void put(text *t, const char *fmt, ...)
{
    va_list ap;
    for (;;) {
        va_start(ap, fmt);
        int k = vsnprintf(t->s ? t->s + t->n : NULL, t->s ? t->cap - t->n : 0, fmt, ap);
        va_end(ap);
        assert_true(k >= 0);
        if (t->s && t->n + (size_t)k < t->cap) {
            t->n += (size_t)k;
            return;
        }
        t->cap = (t->cap + (size_t)k + 1) * 2;
        t->s = realloc(t->s, t->cap);
        assert_non_null(t->s);
    }
}

/* Icosphere of radius r around c, subdivided `sub` times (vertices on the sphere). */
static void icosphere(core_mesh *m, float r, core_vec3 c, int sub)
{
    const float t = 1.6180339887f;
    float v0[12][3] = { { -1, t, 0 }, { 1, t, 0 }, { -1, -t, 0 }, { 1, -t, 0 }, { 0, -1, t }, { 0, 1, t },
                        { 0, -1, -t }, { 0, 1, -t }, { t, 0, -1 }, { t, 0, 1 }, { -t, 0, -1 }, { -t, 0, 1 } };
    uint32_t f0[20][3] = { { 0, 11, 5 }, { 0, 5, 1 }, { 0, 1, 7 }, { 0, 7, 10 }, { 0, 10, 11 }, { 1, 5, 9 }, { 5, 11, 4 },
                           { 11, 10, 2 }, { 10, 7, 6 }, { 7, 1, 8 }, { 3, 9, 4 }, { 3, 4, 2 }, { 3, 2, 6 }, { 3, 6, 8 },
                           { 3, 8, 9 }, { 4, 9, 5 }, { 2, 4, 11 }, { 6, 2, 10 }, { 8, 6, 7 }, { 9, 8, 1 } };
    uint32_t nv = 12, nt = 20, cap_v = 12, cap_t = 20;
    for (int s = 0; s < sub; s++) cap_v += cap_t * 3 / 2, cap_t *= 4;
    float *p = malloc(cap_v * 3 * sizeof *p);
    uint32_t *f = malloc(cap_t * 3 * sizeof *f);
    assert_non_null(p);
    assert_non_null(f);
    for (uint32_t i = 0; i < 12; i++) {
        float l = sqrtf(v0[i][0] * v0[i][0] + v0[i][1] * v0[i][1] + v0[i][2] * v0[i][2]);
        for (int a = 0; a < 3; a++) p[3 * i + a] = v0[i][a] / l;
    }
    memcpy(f, f0, sizeof f0);
    for (int s = 0; s < sub; s++) {
        uint32_t *nf = malloc((size_t)nt * 4 * 3 * sizeof *nf);
        uint32_t (*mid)[3] = malloc((size_t)nt * 3 * sizeof *mid); /* a, b, midpoint */
        uint32_t nmid = 0;
        assert_non_null(nf);
        assert_non_null(mid);
        for (uint32_t k = 0; k < nt; k++) {
            uint32_t m3[3];
            for (int e = 0; e < 3; e++) {
                uint32_t a = f[3 * k + e], b = f[3 * k + (e + 1) % 3], lo = a < b ? a : b, hi = a ^ b ^ lo, x = UINT32_MAX;
                for (uint32_t q = 0; q < nmid; q++)
                    if (mid[q][0] == lo && mid[q][1] == hi) x = mid[q][2];
                if (x == UINT32_MAX) {
                    float w[3], l = 0;
                    for (int a3 = 0; a3 < 3; a3++) w[a3] = p[3 * a + a3] + p[3 * b + a3], l += w[a3] * w[a3];
                    l = sqrtf(l);
                    for (int a3 = 0; a3 < 3; a3++) p[3 * nv + a3] = w[a3] / l;
                    x = nv++;
                    mid[nmid][0] = lo, mid[nmid][1] = hi, mid[nmid][2] = x, nmid++;
                }
                m3[e] = x;
            }
            uint32_t a = f[3 * k], b = f[3 * k + 1], c = f[3 * k + 2];
            uint32_t q[12] = { a, m3[0], m3[2], b, m3[1], m3[0], c, m3[2], m3[1], m3[0], m3[1], m3[2] };
            memcpy(nf + 12 * (size_t)k, q, sizeof q);
        }
        free(mid);
        free(f);
        f = nf;
        nt *= 4;
    }
    assert_int_equal(core_mesh_alloc(m, nv, nt, NULL), CORE_OK);
    for (uint32_t i = 0; i < nv; i++) {
        m->pos[3 * i] = c.x + r * p[3 * i];
        m->pos[3 * i + 1] = c.y + r * p[3 * i + 1];
        m->pos[3 * i + 2] = c.z + r * p[3 * i + 2];
    }
    memcpy(m->tri, f, (size_t)nt * 3 * sizeof *f);
    free(p);
    free(f);
}

/* Axis-aligned box [c - h, c + h] as 12 triangles (quads split along one diagonal). */
static const uint32_t box_quads[6][4] = { { 0, 2, 3, 1 }, { 4, 5, 7, 6 }, { 0, 1, 5, 4 },
                                          { 2, 6, 7, 3 }, { 0, 4, 6, 2 }, { 1, 3, 7, 5 } };
static void box(core_mesh *m, core_vec3 c, core_vec3 h)
{
    assert_int_equal(core_mesh_alloc(m, 8, 12, NULL), CORE_OK);
    for (uint32_t i = 0; i < 8; i++) {
        m->pos[3 * i] = c.x + (i & 1 ? h.x : -h.x);
        m->pos[3 * i + 1] = c.y + (i & 2 ? h.y : -h.y);
        m->pos[3 * i + 2] = c.z + (i & 4 ? h.z : -h.z);
    }
    for (uint32_t q = 0; q < 6; q++) {
        const uint32_t *v = box_quads[q];
        uint32_t t[6] = { v[0], v[1], v[2], v[0], v[2], v[3] };
        memcpy(m->tri + 6 * q, t, sizeof t);
    }
}

static void write_tfxmesh(const core_mesh *m, text *t)
{
    put(t, "# TressFX collision mesh written by test_mesh\nnumOfBones 2\n# bone index, bone name\n0 root\n1 head\n");
    put(t, "numOfVertices %u\n# vertex index, x y z nx ny nz j0..j3 w0..w3\n", m->nverts);
    for (uint32_t i = 0; i < m->nverts; i++)
        put(t, "%u %.9g %.9g %.9g 0 1 0 1 0 0 0 1 0 0 0\n", i, (double)m->pos[3 * i], (double)m->pos[3 * i + 1],
            (double)m->pos[3 * i + 2]);
    put(t, "numOfTriangles %u\n# triangle index, v0 v1 v2\n", m->ntris);
    for (uint32_t i = 0; i < m->ntris; i++) put(t, "%u %u %u %u\n", i, m->tri[3 * i], m->tri[3 * i + 1], m->tri[3 * i + 2]);
}

/* Faces alternate the index forms: i, i/t, i//n, i/t/n, and negative (relative) indices. */
static void write_obj(const core_mesh *m, text *t)
{
    put(t, "# written by test_mesh\r\nmtllib x.mtl\no body\n");
    for (uint32_t i = 0; i < m->nverts; i++)
        put(t, "v\t%.9g %.9g %.9g\nvn 0 1 0\nvt 0.5 0.5\n", (double)m->pos[3 * i], (double)m->pos[3 * i + 1],
            (double)m->pos[3 * i + 2]);
    put(t, "s off\nusemtl skin\n");
    for (uint32_t k = 0; k < m->ntris; k++) {
        put(t, "f");
        for (int c = 0; c < 3; c++) {
            long v = (long)m->tri[3 * k + c] + 1;
            switch ((k + (uint32_t)c) % 5) {
            case 0: put(t, " %ld", v); break;
            case 1: put(t, " %ld/%ld", v, v); break;
            case 2: put(t, " %ld//%ld", v, v); break;
            case 3: put(t, " %ld/%ld/%ld", v, v, v); break;
            default: put(t, " %ld", v - 1 - (long)m->nverts); break;
            }
        }
        put(t, "\r\n");
    }
}

static void assert_same_mesh(const core_mesh *a, const core_mesh *b)
{
    assert_int_equal(a->nverts, b->nverts);
    assert_int_equal(a->ntris, b->ntris);
    assert_memory_equal(a->pos, b->pos, (size_t)a->nverts * 3 * sizeof(float));
    assert_memory_equal(a->tri, b->tri, (size_t)a->ntris * 3 * sizeof(uint32_t));
}

/* Distance from p to segment ab, double. */
static double seg_dist(const double p[3], const double a[3], const double b[3])
{
    double ab[3], ap[3], l = 0, t = 0;
    for (int i = 0; i < 3; i++) ab[i] = b[i] - a[i], ap[i] = p[i] - a[i], l += ab[i] * ab[i], t += ab[i] * ap[i];
    t = l > 0 ? fmin(fmax(t / l, 0), 1) : 0;
    double d = 0;
    for (int i = 0; i < 3; i++) d += (ap[i] - t * ab[i]) * (ap[i] - t * ab[i]);
    return sqrt(d);
}

/* Exact unsigned distance from p to the mesh (every triangle; independent of the library). */
static double brute_dist(const core_mesh *m, core_vec3 pf)
{
    double p[3] = { pf.x, pf.y, pf.z }, best = INFINITY;
    for (uint32_t k = 0; k < m->ntris; k++) {
        double v[3][3];
        for (int c = 0; c < 3; c++)
            for (int i = 0; i < 3; i++) v[c][i] = m->pos[3 * m->tri[3 * k + c] + i];
        double e1[3], e2[3], n[3], ap[3];
        for (int i = 0; i < 3; i++) e1[i] = v[1][i] - v[0][i], e2[i] = v[2][i] - v[0][i], ap[i] = p[i] - v[0][i];
        n[0] = e1[1] * e2[2] - e1[2] * e2[1], n[1] = e1[2] * e2[0] - e1[0] * e2[2], n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        double nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2], h = (n[0] * ap[0] + n[1] * ap[1] + n[2] * ap[2]) / nn;
        double q[3] = { p[0] - h * n[0], p[1] - h * n[1], p[2] - h * n[2] };
        int inside = 1;
        for (int e = 0; e < 3; e++) { /* q on the inner side of each edge */
            const double *a = v[e], *b = v[(e + 1) % 3];
            double ab[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] }, aq[3] = { q[0] - a[0], q[1] - a[1], q[2] - a[2] };
            double c[3] = { ab[1] * aq[2] - ab[2] * aq[1], ab[2] * aq[0] - ab[0] * aq[2], ab[0] * aq[1] - ab[1] * aq[0] };
            if (c[0] * n[0] + c[1] * n[1] + c[2] * n[2] < 0) inside = 0;
        }
        double d = inside ? fabs(h) * sqrt(nn)
                          : fmin(seg_dist(p, v[0], v[1]), fmin(seg_dist(p, v[1], v[2]), seg_dist(p, v[2], v[0])));
        if (d < best) best = d;
    }
    return best;
}

/* 1 when p is strictly inside every face plane of a convex mesh. */
static int convex_inside(const core_mesh *m, core_vec3 p)
{
    for (uint32_t k = 0; k < m->ntris; k++) {
        const float *a = m->pos + 3 * m->tri[3 * k], *b = m->pos + 3 * m->tri[3 * k + 1], *c = m->pos + 3 * m->tri[3 * k + 2];
        double e1[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] }, e2[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
        double n[3] = { e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0] };
        if (n[0] * (p.x - a[0]) + n[1] * (p.y - a[1]) + n[2] * (p.z - a[2]) >= 0) return 0;
    }
    return 1;
}

/* Signed distance to a convex mesh (brute force). */
static double convex_sdist(const core_mesh *m, core_vec3 p)
{
    double d = brute_dist(m, p);
    return convex_inside(m, p) ? -d : d;
}

static core_vec3 grid_pos(const core_sdf *s, uint32_t i, uint32_t j, uint32_t k)
{
    return core_v3(s->origin.x + (float)i * s->cell, s->origin.y + (float)j * s->cell, s->origin.z + (float)k * s->cell);
}

static float grid_at(const core_sdf *s, uint32_t i, uint32_t j, uint32_t k)
{
    return s->d[((size_t)k * s->dims[1] + j) * s->dims[0] + i];
}

/* A convex mesh's grid: the sign of every sample not on the surface is exact; on one sample
 * in `every` (at random) the distance is exact within 3 cells, else never below the truth
 * and at most one cell above it. */
static void check_grid_convex(const core_mesh *m, const core_sdf *s, uint32_t every)
{
    size_t checked = 0;
    for (uint32_t k = 0; k < s->dims[2]; k++)
        for (uint32_t j = 0; j < s->dims[1]; j++)
            for (uint32_t i = 0; i < s->dims[0]; i++) {
                core_vec3 p = grid_pos(s, i, j, k);
                float d = grid_at(s, i, j, k);
                int in = convex_inside(m, p);
                if (in != (d < 0) && fabsf(d) > 1e-6f) /* a sample on the surface may take either sign */
                    fail_msg("sample %u %u %u (%g %g %g): sign of %g, inside %d", i, j, k, (double)p.x, (double)p.y,
                             (double)p.z, (double)d, in);
                if (every > 1 && rnd() * every >= 1.0) continue;
                double t = brute_dist(m, p);
                if (t > 0.0 && in != (d < 0)) fail_msg("sample %u %u %u: %g off the surface (%g) with the wrong sign", i, j, k, (double)d, t);
                double err = fabs(d) - t;
                if (t <= 3.0 * s->cell) {
                    if (fabs(err) > 2e-6) fail_msg("sample %u %u %u: near distance %g, true %g", i, j, k, (double)d, t);
                } else if (err < -2e-6 || err > s->cell)
                    fail_msg("sample %u %u %u: far distance %g, true %g", i, j, k, (double)d, t);
                checked++;
            }
    assert_true(checked * every * 2 > (size_t)s->dims[0] * s->dims[1] * s->dims[2]);
}

/* ---- loaders ------------------------------------------------------------------------- */

static void test_load_roundtrip(void **state)
{
    (void)state;
    core_err e;
    for (int shape = 0; shape < 2; shape++) {
        core_mesh m, a, b;
        if (shape == 0) icosphere(&m, 0.1f, core_v3(0.01f, 0.02f, -0.03f), 2);
        else box(&m, core_v3(0.0f, 0.5f, 0.0f), core_v3(0.1f, 0.05f, 0.2f));
        if (shape == 0) {
            assert_int_equal(m.nverts, 162);
            assert_int_equal(m.ntris, 320);
        }
        assert_int_equal(groom_mesh_check(&m, &e), CORE_OK);
        text o = { 0 }, x = { 0 };
        write_obj(&m, &o);
        write_tfxmesh(&m, &x);
        if (groom_mesh_load_obj(o.s, o.n, &a, &e) != CORE_OK) fail_msg("obj: %s", e.msg);
        if (groom_mesh_load_tfxmesh(x.s, x.n, &b, &e) != CORE_OK) fail_msg("tfxmesh: %s", e.msg);
        assert_same_mesh(&m, &a);
        assert_same_mesh(&m, &b);
        core_mesh_free(&a);
        core_mesh_free(&b);
        free(o.s);
        free(x.s);
        core_mesh_free(&m);
    }
    /* quads and an n-gon, fan-triangulated: a box written as six quads */
    text o = { 0 };
    for (int i = 0; i < 8; i++) put(&o, "v %d %d %d\n", i & 1, (i >> 1) & 1, (i >> 2) & 1);
    for (int q = 0; q < 6; q++)
        put(&o, "f %u %u %u %u\n", box_quads[q][0] + 1, box_quads[q][1] + 1, box_quads[q][2] + 1, box_quads[q][3] + 1);
    core_mesh a;
    if (groom_mesh_load_obj(o.s, o.n, &a, &e) != CORE_OK) fail_msg("quads: %s", e.msg);
    assert_int_equal(a.nverts, 8);
    assert_int_equal(a.ntris, 12);
    core_mesh_free(&a);
    free(o.s);
}

static void expect_fail(core_status (*load)(const void *, size_t, core_mesh *, core_err *), const char *txt,
                        const char *fragment)
{
    core_err e;
    core_mesh m;
    memset(&e, 0, sizeof e);
    core_status st = load(txt, strlen(txt), &m, &e);
    if (st == CORE_OK) fail_msg("accepted, expected '%s': %.60s", fragment, txt);
    assert_null(m.pos);
    assert_null(m.tri);
    if (!strstr(e.msg, fragment)) fail_msg("message '%s' lacks '%s'", e.msg, fragment);
}

/* A tetrahedron (CCW outside) as .obj text with face lines f[0..3], followed by extra text. */
static const char *tet_v = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";

static void test_obj_broken(void **state)
{
    (void)state;
    char buf[512];
    core_mesh m;
    core_err e;
    snprintf(buf, sizeof buf, "%sf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n", tet_v);
    if (groom_mesh_load_obj(buf, strlen(buf), &m, &e) != CORE_OK) fail_msg("tet: %s", e.msg);
    core_mesh_free(&m);
    snprintf(buf, sizeof buf, "%sf 1 3 2\nf 1 2 4\nf 1 4 3\n", tet_v);
    expect_fail(groom_mesh_load_obj, buf, "not closed");
    snprintf(buf, sizeof buf, "%sf 1 3 2\nf 1 4 2\nf 1 4 3\nf 2 3 4\n", tet_v);
    expect_fail(groom_mesh_load_obj, buf, "inconsistent orientation");
    snprintf(buf, sizeof buf, "%sf 1 2 3\nf 1 4 2\nf 1 3 4\nf 2 4 3\n", tet_v); /* inside out */
    expect_fail(groom_mesh_load_obj, buf, "counter-clockwise");
    /* two tetrahedra sharing the edge 1-2: that edge is in four triangles */
    snprintf(buf, sizeof buf, "%sv 0 -1 0\nv 0 0 -1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
                              "f 1 5 2\nf 1 2 6\nf 1 6 5\nf 2 5 6\n", tet_v);
    expect_fail(groom_mesh_load_obj, buf, "not manifold");
    snprintf(buf, sizeof buf, "v 0 0 nan\n%sf 1 3 2\n", tet_v);
    expect_fail(groom_mesh_load_obj, buf, "line 1: vertex coordinate nan is not finite");
    snprintf(buf, sizeof buf, "v 0 0 1e3\n");
    expect_fail(groom_mesh_load_obj, buf, "beyond");
    snprintf(buf, sizeof buf, "%sf 1 3 5\n", tet_v);
    expect_fail(groom_mesh_load_obj, buf, "line 5: vertex index 5 out of range (4 vertices so far)");
    snprintf(buf, sizeof buf, "%sf -1 -2 -5\n", tet_v);
    expect_fail(groom_mesh_load_obj, buf, "vertex index -5 out of range");
    snprintf(buf, sizeof buf, "%sf 0 1 2\n", tet_v);
    expect_fail(groom_mesh_load_obj, buf, "vertex index 0 out of range");
    snprintf(buf, sizeof buf, "%sf 1 3 3\n", tet_v);
    expect_fail(groom_mesh_load_obj, buf, "line 5: degenerate triangle");
    snprintf(buf, sizeof buf, "%sf 1 3\n", tet_v);
    expect_fail(groom_mesh_load_obj, buf, "at least 3 vertices");
    snprintf(buf, sizeof buf, "%sf 1 x 3\n", tet_v);
    expect_fail(groom_mesh_load_obj, buf, "bad face vertex");
    snprintf(buf, sizeof buf, "v 1 2\n");
    expect_fail(groom_mesh_load_obj, buf, "needs 3 numbers");
    expect_fail(groom_mesh_load_obj, "", "empty mesh");
    expect_fail(groom_mesh_load_obj, "# nothing\n\n", "empty mesh");
    expect_fail(groom_mesh_load_obj, tet_v, "empty mesh");
    expect_fail(groom_mesh_load_obj, "v 0 0 0\n\001\002garbage", "binary data");
    char *longl = malloc(GROOM_MESH_MAX_LINE + 64);
    assert_non_null(longl);
    memset(longl, ' ', GROOM_MESH_MAX_LINE + 10);
    memcpy(longl, "# ", 2);
    longl[GROOM_MESH_MAX_LINE + 10] = '\0';
    expect_fail(groom_mesh_load_obj, longl, "longer than");
    free(longl);
    /* not NUL-terminated: the loader must stop at size (ASan catches a read past it) */
    snprintf(buf, sizeof buf, "%sf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4", tet_v);
    size_t n = strlen(buf);
    char *exact = malloc(n);
    assert_non_null(exact);
    memcpy(exact, buf, n);
    assert_int_equal(groom_mesh_load_obj(exact, n, &m, &e), CORE_OK);
    core_mesh_free(&m);
    free(exact);
    assert_int_equal(groom_mesh_load_obj(NULL, 0, &m, &e), CORE_EFORMAT);
}

static void test_tfxmesh_broken(void **state)
{
    (void)state;
    const char *ok = "numOfVertices 4\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n"
                     "numOfTriangles 4\n0 0 2 1\n1 0 1 3\n2 0 3 2\n3 1 2 3\n";
    core_mesh m;
    core_err e;
    if (groom_mesh_load_tfxmesh(ok, strlen(ok), &m, &e) != CORE_OK) fail_msg("%s", e.msg);
    core_mesh_free(&m);
    expect_fail(groom_mesh_load_tfxmesh, "", "empty file");
    expect_fail(groom_mesh_load_tfxmesh, "# only a comment\n", "empty file");
    expect_fail(groom_mesh_load_tfxmesh, "numOfVertices 99999999\n0 0 0 0\n", "numOfVertices 99999999 out of range");
    expect_fail(groom_mesh_load_tfxmesh, "numOfVertices 0\n", "out of range");
    expect_fail(groom_mesh_load_tfxmesh, "numOfVertices -3\n", "out of range");
    expect_fail(groom_mesh_load_tfxmesh, "numOfBones 70000\n", "numOfBones 70000 out of range");
    expect_fail(groom_mesh_load_tfxmesh, "numOfBones 2\n0 a\n", "expecting bone 1 of 2");
    expect_fail(groom_mesh_load_tfxmesh, "vertices 4\n", "expected 'numOfVertices N'");
    expect_fail(groom_mesh_load_tfxmesh, "numOfVertices 2\n0 0 0 0\n5 0 0 0\n", "line 3: vertex index 5, expected 1");
    expect_fail(groom_mesh_load_tfxmesh, "numOfVertices 1\n0 0 inf 0\n", "not finite");
    expect_fail(groom_mesh_load_tfxmesh, "numOfVertices 1\n0 0 0\n", "vertex 0 needs 3 numbers");
    expect_fail(groom_mesh_load_tfxmesh, "numOfVertices 4\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n", "expecting numOfTriangles");
    expect_fail(groom_mesh_load_tfxmesh,
                "numOfVertices 4\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\nnumOfTriangles 1\n0 0 2 4\n",
                "line 7: triangle 0: vertex index 4 out of range (4 vertices)");
    expect_fail(groom_mesh_load_tfxmesh,
                "numOfVertices 4\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\nnumOfTriangles 1\n0 0 2 -1\n", "index -1 out of range");
    expect_fail(groom_mesh_load_tfxmesh,
                "numOfVertices 4\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\nnumOfTriangles 1\n0 0 2 2\n", "degenerate");
    expect_fail(groom_mesh_load_tfxmesh,
                "numOfVertices 4\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\nnumOfTriangles 1\n0 0 2 1 7\n", "needs 3 vertex indices");
    char buf[512];
    snprintf(buf, sizeof buf, "%sextra\n", ok);
    expect_fail(groom_mesh_load_tfxmesh, buf, "unexpected data after the 4 triangles");
    snprintf(buf, sizeof buf, "%s", ok);
    buf[strlen(buf) - 2] = '\0'; /* last triangle cut to "3 1 2" */
    expect_fail(groom_mesh_load_tfxmesh, buf, "needs 3 vertex indices");
    expect_fail(groom_mesh_load_tfxmesh, "numOfVertices 1\n0 0 0 0\n\x7f\x45LF", "binary data");
}

/* Cut at every line end and many byte offsets, and thousands of random byte flips: never a
 * crash (ASan), every cut refused, every accepted flip a valid mesh. */
static void test_truncation_and_flips(void **state)
{
    (void)state;
    core_mesh m, out;
    core_err e;
    icosphere(&m, 0.1f, core_v3(0, 0, 0), 1);
    text t = { 0 }, o = { 0 };
    write_tfxmesh(&m, &t);
    write_obj(&m, &o);
    char *cut = malloc(t.n + 1);
    assert_non_null(cut);
    for (size_t n = 0; n < t.n; n++) {
        if ((t.s[n] != '\n' && n % 7 != 0) || n + 1 == t.n) continue;
        memcpy(cut, t.s, n); /* not NUL-terminated past n: the loader must not look */
        if (groom_mesh_load_tfxmesh(cut, n, &out, &e) == CORE_OK) fail_msg("cut at byte %zu of %zu accepted", n, t.n);
    }
    for (size_t n = 0; n + 16 < o.n; n += 13) /* (the last face line is short: cut before it) */
        if (groom_mesh_load_obj(o.s, n, &out, &e) == CORE_OK) fail_msg("obj cut at %zu of %zu accepted", n, o.n);
    char *f = malloc(t.n > o.n ? t.n : o.n);
    assert_non_null(f);
    uint32_t accepted = 0;
    for (int it = 0; it < 3000; it++) {
        const text *src = it & 1 ? &o : &t;
        memcpy(f, src->s, src->n);
        int flips = 1 + (int)(rnd() * 4);
        for (int k = 0; k < flips; k++) f[(size_t)(rnd() * (double)src->n)] = (char)(rnd() * 256);
        core_status st = it & 1 ? groom_mesh_load_obj(f, src->n, &out, &e) : groom_mesh_load_tfxmesh(f, src->n, &out, &e);
        if (st == CORE_OK) {
            assert_int_equal(groom_mesh_check(&out, &e), CORE_OK);
            core_mesh_free(&out);
            accepted++;
        } else {
            assert_true(e.msg[0] != '\0');
        }
    }
    print_message("flips: %u of 3000 accepted (valid meshes)\n", accepted);
    free(f);
    free(cut);
    free(t.s);
    free(o.s);
    core_mesh_free(&m);
}

static void test_load_file(void **state)
{
    (void)state;
    core_mesh m, a;
    core_err e;
    box(&m, core_v3(0, 0, 0), core_v3(0.1f, 0.1f, 0.1f));
    char dir[] = "/tmp/strandcast_meshXXXXXX";
    assert_non_null(mkdtemp(dir));
    char p1[256], p2[256], p3[256];
    snprintf(p1, sizeof p1, "%s/box.OBJ", dir);
    snprintf(p2, sizeof p2, "%s/box.TfxMesh", dir);
    snprintf(p3, sizeof p3, "%s/box.stl", dir);
    text o = { 0 }, t = { 0 };
    write_obj(&m, &o);
    write_tfxmesh(&m, &t);
    FILE *fp = fopen(p1, "wb");
    assert_non_null(fp);
    fwrite(o.s, 1, o.n, fp);
    fclose(fp);
    fp = fopen(p2, "wb");
    assert_non_null(fp);
    fwrite(t.s, 1, t.n, fp);
    fclose(fp);
    if (groom_mesh_load_file(p1, &a, &e) != CORE_OK) fail_msg("%s", e.msg);
    assert_same_mesh(&m, &a);
    core_mesh_free(&a);
    if (groom_mesh_load_file(p2, &a, &e) != CORE_OK) fail_msg("%s", e.msg);
    assert_same_mesh(&m, &a);
    core_mesh_free(&a);
    assert_int_equal(groom_mesh_load_file(p3, &a, &e), CORE_EINVAL);
    assert_non_null(strstr(e.msg, "unknown extension"));
    snprintf(p3, sizeof p3, "%s/missing.obj", dir);
    assert_int_equal(groom_mesh_load_file(p3, &a, &e), CORE_EIO);
    fp = fopen(p1, "wb");
    assert_non_null(fp);
    fputs("v 0 0 0\nf 1 1 1\n", fp);
    fclose(fp);
    assert_int_equal(groom_mesh_load_file(p1, &a, &e), CORE_EFORMAT);
    assert_non_null(strstr(e.msg, p1));
    assert_non_null(strstr(e.msg, "degenerate"));
    unlink(p1);
    unlink(p2);
    rmdir(dir);
    free(o.s);
    free(t.s);
    core_mesh_free(&m);
}

/* ---- distance grids ------------------------------------------------------------------ */

static void test_sdf_sphere(void **state)
{
    (void)state;
    const float R = 0.1f;
    core_mesh m;
    core_sdf s;
    core_err e;
    icosphere(&m, R, core_v3(0, 0, 0), 2);
    /* the faceted sphere lies between R - facet (its nearest face from the centre) and R */
    double facet = R - brute_dist(&m, core_v3(0, 0, 0));
    assert_true(facet > 0.0 && facet < 0.01);
    groom_sdf_desc d = { .cell = 0.005f };
    if (groom_sdf_build(&m, &d, &s, &e) != CORE_OK) fail_msg("%s", e.msg);
    assert_true(s.cell == 0.005f);
    for (int a = 0; a < 3; a++) assert_true(s.dims[a] >= (uint32_t)(0.2f / 0.005f) + 8);
    assert_true(s.origin.x <= -R - 3.9f * s.cell && s.origin.x > -R - 5.1f * s.cell);
    check_grid_convex(&m, &s, 16);
    /* interpolated values and gradients at random points within 0.5 R of the surface */
    int near = 0;
    for (int it = 0; it < 20000; it++) {
        core_vec3 dir = core_v3_norm(core_v3((float)(rnd() * 2 - 1), (float)(rnd() * 2 - 1), (float)(rnd() * 2 - 1)));
        float r = (float)(R * (0.5 + rnd() * 1.0));
        core_vec3 p = core_v3_scale(dir, r), g;
        float v = core_sdf_sample(&s, p, &g);
        double truth = r - R;
        if (fabs(v - truth) > facet + 0.5 * s.cell)
            fail_msg("r %g: sampled %g, sphere %g (facet %g)", (double)r, (double)v, truth, facet);
        if (fabs(truth) > facet + 0.5 * s.cell && (v < 0) != (truth < 0)) fail_msg("r %g: sign of %g", (double)r, (double)v);
        if (fabs(truth) < 2.0 * s.cell) {
            near++;
            float c = core_v3_dot(core_v3_norm(g), dir);
            if (c < 0.9f) fail_msg("r %g: gradient (%g %g %g) . radial = %g", (double)r, (double)g.x, (double)g.y, (double)g.z, (double)c);
            assert_true(core_v3_len(g) > 0.8f && core_v3_len(g) < 1.2f);
        }
    }
    assert_true(near > 1000);
    /* outside the grid: box distance added, gradient away from the box */
    core_vec3 g;
    float far = core_sdf_sample(&s, core_v3(1.0f, 0.0f, 0.0f), &g);
    assert_true(fabs(far - (1.0 - R)) < facet + s.cell);
    /* x is clamped: exactly the unit x; y and z the interpolant's (the facets tilt it a little) */
    if (!(g.x == 1.0f && fabsf(g.y) < 0.3f && fabsf(g.z) < 0.3f)) fail_msg("far gradient %g %g %g", (double)g.x, (double)g.y, (double)g.z);
    far = core_sdf_sample(&s, core_v3(-0.5f, 0.5f, 0.02f), &g); /* clamped on x and y, not z */
    assert_true(far > 0.5f);
    assert_true(g.x < -0.6f && g.y > 0.6f && fabsf(g.z) < 0.5f);
    assert_true(fabsf(core_sdf_sample(&s, core_v3(0, 0, 0), NULL) + R) < facet + s.cell);
    assert_true(isnan(core_sdf_sample(&s, core_v3(NAN, 0, 0), &g)));
    /* at a sample the interpolant is the sample */
    assert_true(core_sdf_sample(&s, grid_pos(&s, 3, 4, 5), NULL) == grid_at(&s, 3, 4, 5));
    assert_true(core_sdf_sample(&s, grid_pos(&s, s.dims[0] - 1, s.dims[1] - 1, s.dims[2] - 1), NULL) ==
                grid_at(&s, s.dims[0] - 1, s.dims[1] - 1, s.dims[2] - 1));
    core_sdf_free(&s);
    core_mesh_free(&m);
}

/* Box faces, edges and vertices exactly on grid lines (binary-exact sizes): the winding
 * tie-break must count each crossing once; plus a rotated box and a region that cuts the mesh. */
static void test_sdf_box(void **state)
{
    (void)state;
    core_mesh m;
    core_sdf s;
    core_err e;
    box(&m, core_v3(0, 0, 0), core_v3(4.0f / 64, 3.0f / 64, 5.0f / 64));
    groom_sdf_desc d = { .cell = 1.0f / 64, .lo = core_v3(-4.0f / 64, -3.0f / 64, -5.0f / 64),
                         .hi = core_v3(4.0f / 64, 3.0f / 64, 5.0f / 64) };
    if (groom_sdf_build(&m, &d, &s, &e) != CORE_OK) fail_msg("%s", e.msg);
    assert_true(s.origin.x == -6.0f / 64 && s.origin.y == -5.0f / 64 && s.origin.z == -7.0f / 64);
    check_grid_convex(&m, &s, 1);
    core_sdf_free(&s);
    core_mesh_free(&m);
    /* rotated and off-centre */
    box(&m, core_v3(0.013f, -0.021f, 0.007f), core_v3(0.05f, 0.03f, 0.08f));
    core_quat q = core_q_norm((core_quat){ 0.3f, -0.5f, 0.2f, 0.8f });
    for (uint32_t v = 0; v < m.nverts; v++) {
        core_vec3 p = core_q_rotate(q, core_v3(m.pos[3 * v], m.pos[3 * v + 1], m.pos[3 * v + 2]));
        m.pos[3 * v] = p.x, m.pos[3 * v + 1] = p.y, m.pos[3 * v + 2] = p.z;
    }
    groom_sdf_desc d2 = { .cell = 0.004f };
    if (groom_sdf_build(&m, &d2, &s, &e) != CORE_OK) fail_msg("%s", e.msg);
    check_grid_convex(&m, &s, 1);
    core_sdf_free(&s);
    /* a region through the middle of the box: signs still exact */
    groom_sdf_desc d3 = { .cell = 0.003f, .lo = core_v3(-0.02f, 0.0f, -0.03f), .hi = core_v3(0.03f, 0.1f, 0.02f) };
    if (groom_sdf_build(&m, &d3, &s, &e) != CORE_OK) fail_msg("%s", e.msg);
    for (uint32_t k = 0; k < s.dims[2]; k++)
        for (uint32_t j = 0; j < s.dims[1]; j++)
            for (uint32_t i = 0; i < s.dims[0]; i++) {
                double t = convex_sdist(&m, grid_pos(&s, i, j, k));
                float v = grid_at(&s, i, j, k);
                if ((t < 0) != (v < 0)) fail_msg("cut region sample %u %u %u: %g, true %g", i, j, k, (double)v, t);
                if (fabs(t) <= 3 * s.cell) assert_true(fabs(fabs(v) - fabs(t)) < 2e-6);
                else assert_true(fabs(v) >= fabs(t) - 2e-6);
            }
    core_sdf_free(&s);
    core_mesh_free(&m);
}

static void test_sdf_desc(void **state)
{
    (void)state;
    core_mesh m;
    core_sdf s;
    core_err e;
    icosphere(&m, 0.1f, core_v3(0, 0, 0), 1);
    /* max_cells forces a coarser cell, never a failure */
    groom_sdf_desc d = { .cell = 0.001f, .max_cells = 20000 };
    if (groom_sdf_build(&m, &d, &s, &e) != CORE_OK) fail_msg("%s", e.msg);
    assert_true((double)s.dims[0] * s.dims[1] * s.dims[2] <= 20000);
    assert_true(s.cell > 0.001f);
    check_grid_convex(&m, &s, 1);
    core_sdf_free(&s);
    d.max_cells = 1; /* raised to the minimum */
    assert_int_equal(groom_sdf_build(&m, &d, &s, &e), CORE_OK);
    assert_true((double)s.dims[0] * s.dims[1] * s.dims[2] <= 4096);
    core_sdf_free(&s);
    /* a region far from the mesh: no triangle in the band, distances from the brute seeds */
    groom_sdf_desc far = { .cell = 0.01f, .lo = core_v3(0.5f, 0.5f, 0.5f), .hi = core_v3(0.6f, 0.6f, 0.6f) };
    assert_int_equal(groom_sdf_build(&m, &far, &s, &e), CORE_OK);
    check_grid_convex(&m, &s, 1);
    core_sdf_free(&s);
    groom_sdf_desc bad = { .cell = -1.0f };
    assert_int_equal(groom_sdf_build(&m, &bad, &s, &e), CORE_EINVAL);
    assert_null(s.d);
    groom_sdf_desc empty = { .lo = core_v3(0, 0, 0), .hi = core_v3(1, 0, 1) };
    assert_int_equal(groom_sdf_build(&m, &empty, &s, &e), CORE_EINVAL);
    assert_non_null(strstr(e.msg, "empty"));
    groom_sdf_desc nan = { .lo = core_v3(NAN, 0, 0), .hi = core_v3(1, 1, 1) };
    assert_int_equal(groom_sdf_build(&m, &nan, &s, &e), CORE_EINVAL);
    m.tri[0] = m.tri[1]; /* a broken mesh is refused */
    assert_int_equal(groom_sdf_build(&m, NULL, &s, &e), CORE_EFORMAT);
    assert_non_null(strstr(e.msg, "degenerate"));
    core_mesh_free(&m);
}

static void test_groom_owns_mesh_and_sdf(void **state)
{
    (void)state;
    core_err e;
    core_groom g, c;
    assert_int_equal(core_groom_alloc(&g, 3, 4, &e), CORE_OK);
    assert_null(g.mesh);
    assert_null(g.sdf);
    assert_int_equal(core_groom_copy(&c, &g, &e), CORE_OK); /* without: stays without */
    assert_null(c.mesh);
    assert_null(c.sdf);
    core_groom_free(&c);
    g.mesh = calloc(1, sizeof *g.mesh);
    g.sdf = calloc(1, sizeof *g.sdf);
    assert_non_null(g.mesh);
    assert_non_null(g.sdf);
    icosphere(g.mesh, 0.1f, core_v3(0, 0, 0), 1);
    groom_sdf_desc d = { .cell = 0.01f };
    assert_int_equal(groom_sdf_build(g.mesh, &d, g.sdf, &e), CORE_OK);
    assert_int_equal(core_groom_copy(&c, &g, &e), CORE_OK);
    assert_true(c.mesh && c.mesh != g.mesh && c.mesh->pos != g.mesh->pos);
    assert_same_mesh(g.mesh, c.mesh);
    assert_true(c.sdf && c.sdf != g.sdf && c.sdf->d != g.sdf->d);
    assert_memory_equal(c.sdf->dims, g.sdf->dims, sizeof c.sdf->dims);
    assert_true(c.sdf->cell == g.sdf->cell && c.sdf->origin.x == g.sdf->origin.x);
    assert_memory_equal(c.sdf->d, g.sdf->d, (size_t)g.sdf->dims[0] * g.sdf->dims[1] * g.sdf->dims[2] * sizeof(float));
    core_groom_free(&g);
    assert_null(g.mesh);
    assert_null(g.sdf);
    core_groom_free(&g); /* twice is fine */
    assert_true(core_sdf_sample(c.sdf, core_v3(0, 0, 0), NULL) < 0.0f);
    core_groom_free(&c);
    core_sdf s, s2;
    uint32_t dims[3] = { 1, 2, 2 };
    assert_int_equal(core_sdf_alloc(&s, dims, core_v3(0, 0, 0), 0.1f, &e), CORE_EINVAL);
    dims[0] = 2;
    assert_int_equal(core_sdf_alloc(&s, dims, core_v3(0, 0, 0), 0.0f, &e), CORE_EINVAL);
    assert_int_equal(core_sdf_alloc(&s, dims, core_v3(0, 0, 0), 0.5f, &e), CORE_OK);
    for (int i = 0; i < 8; i++) s.d[i] = (float)((i & 1) + 2 * ((i >> 1) & 1) + 4 * (i >> 2)); /* x + 2y + 4z, in cells */
    core_vec3 g2;
    float v = core_sdf_sample(&s, core_v3(0.25f, 0.1f, 0.4f), &g2);
    assert_true(fabsf(v - (0.5f + 2 * 0.2f + 4 * 0.8f)) < 1e-6f);
    assert_true(fabsf(g2.x - 2.0f) < 1e-5f && fabsf(g2.y - 4.0f) < 1e-5f && fabsf(g2.z - 8.0f) < 1e-5f);
    assert_int_equal(core_sdf_copy(&s2, &s, &e), CORE_OK);
    assert_memory_equal(s2.d, s.d, 8 * sizeof(float));
    core_sdf_free(&s);
    core_sdf_free(&s2);
    core_sdf_free(&s2);
}

/* ---- Ratboy -------------------------------------------------------------------------- */

static void test_ratboy(void **state)
{
    (void)state;
    const char *assets = getenv("STRANDCAST_ASSETS");
    char path[4096];
    if (!assets) skip();
    snprintf(path, sizeof path, "%s/ratboy/Ratboy_body.tfxmesh", assets);
    if (access(path, R_OK) != 0) skip();
    core_mesh m;
    core_err e;
    if (groom_mesh_load_file(path, &m, &e) != CORE_OK) fail_msg("%s", e.msg);
    assert_int_equal(m.nverts, 12909);
    assert_int_equal(m.ntris, 25814);
    assert_int_equal(groom_mesh_check(&m, &e), CORE_OK); /* closed, manifold, oriented */
    /* the head is the top of the body (y up, 0.91 m tall): the vertices above y = 0.6 m */
    groom_sdf_desc d = { .lo = core_v3(INFINITY, 0.6f, INFINITY), .hi = core_v3(-INFINITY, -INFINITY, -INFINITY) };
    core_vec3 cen = core_v3(0, 0, 0), top = core_v3(0, -1, 0);
    uint32_t nh = 0;
    for (uint32_t v = 0; v < m.nverts; v++) {
        core_vec3 p = core_v3(m.pos[3 * v], m.pos[3 * v + 1], m.pos[3 * v + 2]);
        if (p.y <= 0.6f) continue;
        nh++;
        cen = core_v3_add(cen, p);
        if (p.y > top.y) top = p;
        d.lo = core_v3(fminf(d.lo.x, p.x), d.lo.y, fminf(d.lo.z, p.z));
        d.hi = core_v3(fmaxf(d.hi.x, p.x), fmaxf(d.hi.y, p.y), fmaxf(d.hi.z, p.z));
    }
    assert_true(nh > 1000);
    cen = core_v3_scale(cen, 1.0f / (float)nh);
    core_sdf s;
    unsigned long long t0 = core_now_ns();
    if (groom_sdf_build(&m, &d, &s, &e) != CORE_OK) fail_msg("%s", e.msg);
    double ms = (double)(core_now_ns() - t0) / 1e6;
    print_message("Ratboy head SDF: %u x %u x %u samples (%.2f M), cell %g m, built in %.0f ms\n", s.dims[0], s.dims[1],
                  s.dims[2], (double)s.dims[0] * s.dims[1] * s.dims[2] / 1e6, (double)s.cell, ms);
    assert_true(s.cell == GROOM_SDF_DEFAULT_CELL);
    float dc = core_sdf_sample(&s, cen, NULL);
    float da = core_sdf_sample(&s, core_v3_add(top, core_v3(0, 0.05f, 0)), NULL);
    print_message("head centroid (%g %g %g): %g m; 5 cm above the top: %g m\n", (double)cen.x, (double)cen.y,
                  (double)cen.z, (double)dc, (double)da);
    assert_true(dc < 0.0f);
    assert_true(da > 0.045f && da < 0.055f);
    /* random samples within 3 cells of the surface: exact against every triangle */
    int checked = 0;
    for (int it = 0; it < 200000 && checked < 150; it++) {
        uint32_t i = (uint32_t)(rnd() * s.dims[0]), j = (uint32_t)(rnd() * s.dims[1]), k = (uint32_t)(rnd() * s.dims[2]);
        float v = grid_at(&s, i, j, k);
        if (fabsf(v) > 3.0f * s.cell) continue;
        double t = brute_dist(&m, grid_pos(&s, i, j, k));
        if (fabs(fabs(v) - t) > 5e-6) fail_msg("sample %u %u %u: %g, true distance %g", i, j, k, (double)v, t);
        checked++;
    }
    assert_int_equal(checked, 150);
    core_sdf_free(&s);
    core_mesh_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_load_roundtrip),
        cmocka_unit_test(test_obj_broken),
        cmocka_unit_test(test_tfxmesh_broken),
        cmocka_unit_test(test_truncation_and_flips),
        cmocka_unit_test(test_load_file),
        cmocka_unit_test(test_sdf_sphere),
        cmocka_unit_test(test_sdf_box),
        cmocka_unit_test(test_sdf_desc),
        cmocka_unit_test(test_groom_owns_mesh_and_sdf),
        cmocka_unit_test(test_ratboy),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
