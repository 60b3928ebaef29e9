/* tests: hair meshes (core/hairmesh_types, groom_hairmesh*): the structure's checks and copies, the
 * tracing rule, the procedural styles, guide strands, and the layered .obj convention (round
 * trip, an example file, malformed and hostile input). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/groom_types.h"
#include "groom/groom.h"

/* Two quads side by side (columns 0-5) and a triangle (columns 1, 4, 6), 3 layers, extruded
 * along +y with a shear along x. */
static void small_mesh(core_hairmesh *m)
{
    assert_int_equal(core_hairmesh_alloc(m, 7, 3, 3, 0, 0, NULL), CORE_OK);
    const float base[7][2] = { { 0, 0 }, { 1, 0 }, { 2, 0 }, { 0, 1 }, { 1, 1 }, { 2, 1 }, { 1, -1 } };
    for (uint32_t c = 0; c < 7; c++)
        for (uint32_t l = 0; l < 3; l++) {
            float *p = m->pos + 3 * (c * 3 + l);
            p[0] = 0.01f * base[c][0] + 0.005f * (float)l, p[1] = 0.02f * (float)l, p[2] = -0.01f * base[c][1];
        }
    const uint32_t f[3][4] = { { 0, 1, 4, 3 }, { 1, 2, 5, 4 }, { 1, 0, 6, CORE_HAIRMESH_NONE } };
    memcpy(m->faces, f, sizeof f);
}

static void test_alloc_validate_copy(void **state)
{
    (void)state;
    core_err err;
    core_hairmesh m, c;
    assert_int_equal(core_hairmesh_alloc(&m, 2, 3, 1, 0, 0, &err), CORE_EINVAL);
    assert_int_equal(core_hairmesh_alloc(&m, 3, 1, 1, 0, 0, &err), CORE_EINVAL);
    assert_int_equal(core_hairmesh_alloc(&m, 3, 2, 0, 0, 0, &err), CORE_EINVAL);
    assert_int_equal(core_hairmesh_alloc(&m, 3, 2, 1, 4, 1, &err), CORE_EINVAL); /* guides of one vertex */
    assert_int_equal(core_hairmesh_alloc(&m, 3, 2, 1, CORE_HAIRMESH_MAX_GUIDES, 64, &err), CORE_EINVAL);
    assert_int_equal(core_hairmesh_alloc(&m, CORE_HAIRMESH_MAX_VERTS, 2, 1, 0, 0, &err), CORE_EINVAL);
    small_mesh(&m);
    assert_int_equal(core_hairmesh_validate(&m, &err), CORE_OK);
    assert_int_equal(core_hairmesh_copy(&c, &m, &err), CORE_OK);
    assert_memory_equal(c.pos, m.pos, 7 * 3 * 3 * sizeof(float));
    assert_memory_equal(c.faces, m.faces, 3 * 4 * sizeof(uint32_t));

    m.faces[1] = 7; /* out of range */
    assert_int_equal(core_hairmesh_validate(&m, &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "out of range"));
    m.faces[1] = 0; /* repeated */
    assert_int_equal(core_hairmesh_validate(&m, &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "twice"));
    m.faces[1] = 1;
    m.faces[4 * 2 + 2] = 4; /* column 6 no longer used */
    assert_int_equal(core_hairmesh_validate(&m, &err), CORE_EFORMAT);
    m.faces[4 * 2 + 2] = 6;
    m.pos[5] = NAN;
    assert_int_equal(core_hairmesh_validate(&m, &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "not finite"));
    m.pos[5] = 1e9f;
    assert_int_equal(core_hairmesh_validate(&m, &err), CORE_EFORMAT);
    m.pos[5] = 0.0f;
    assert_int_equal(core_hairmesh_validate(&m, &err), CORE_OK);
    core_hairmesh_free(&m);

    /* an edge shared by three faces */
    assert_int_equal(core_hairmesh_alloc(&m, 5, 2, 3, 0, 0, NULL), CORE_OK);
    const uint32_t f3[3][4] = { { 0, 1, 2, CORE_HAIRMESH_NONE }, { 1, 0, 3, CORE_HAIRMESH_NONE }, { 0, 1, 4, CORE_HAIRMESH_NONE } };
    memcpy(m.faces, f3, sizeof f3);
    assert_int_equal(core_hairmesh_validate(&m, &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "more than two faces"));
    core_hairmesh_free(&m);

    /* guides outside their face, layer parameters out of order or past the tip */
    small_mesh(&m);
    core_hairmesh g;
    assert_int_equal(core_hairmesh_alloc(&g, 7, 3, 3, 2, 3, NULL), CORE_OK);
    assert_int_equal(g.guide_nverts, 3);
    memcpy(g.pos, m.pos, 7 * 9 * sizeof(float));
    memcpy(g.faces, m.faces, 12 * sizeof(uint32_t));
    g.guide_face[0] = 2, g.guide_uv[0] = 0.3f, g.guide_uv[1] = 0.3f;
    g.guide_face[1] = 0, g.guide_uv[2] = 1.0f, g.guide_uv[3] = 1.0f;
    const float gt[6] = { 0.0f, 0.5f, 2.0f, 0.0f, 1.5f, 2.0f };
    memcpy(g.guide_t, gt, sizeof gt);
    assert_int_equal(core_hairmesh_validate(&g, &err), CORE_OK);
    core_hairmesh gcopy;
    assert_int_equal(core_hairmesh_copy(&gcopy, &g, &err), CORE_OK);
    assert_int_equal(gcopy.guide_nverts, 3);
    assert_memory_equal(gcopy.guide_t, gt, sizeof gt);
    core_hairmesh_free(&gcopy);
    g.guide_uv[0] = 0.8f; /* u + v > 1 on the triangle */
    assert_int_equal(core_hairmesh_validate(&g, &err), CORE_EFORMAT);
    g.guide_uv[0] = 0.3f, g.guide_face[1] = 3;
    assert_int_equal(core_hairmesh_validate(&g, &err), CORE_EFORMAT);
    g.guide_face[1] = 0, g.guide_t[5] = 1.0f; /* behind the vertex before it */
    assert_int_equal(core_hairmesh_validate(&g, &err), CORE_EFORMAT);
    assert_non_null(strstr(err.msg, "layer parameter"));
    g.guide_t[5] = 2.01f; /* past the tip layer */
    assert_int_equal(core_hairmesh_validate(&g, &err), CORE_EFORMAT);
    g.guide_t[5] = NAN;
    assert_int_equal(core_hairmesh_validate(&g, &err), CORE_EFORMAT);
    g.guide_t[5] = 2.0f, g.guide_t[0] = -0.1f;
    assert_int_equal(core_hairmesh_validate(&g, &err), CORE_EFORMAT);
    g.guide_t[0] = 0.0f, g.guide_nverts = 1;
    assert_int_equal(core_hairmesh_validate(&g, &err), CORE_EFORMAT);
    g.guide_nverts = 3;
    assert_int_equal(core_hairmesh_validate(&g, &err), CORE_OK);
    core_hairmesh_free(&g);

    /* the groom owns, frees and deep-copies its hair mesh */
    core_groom gr, gc;
    assert_int_equal(core_groom_alloc(&gr, 1, 2, NULL), CORE_OK);
    gr.hairmesh = malloc(sizeof *gr.hairmesh);
    *gr.hairmesh = m;
    assert_int_equal(core_groom_copy(&gc, &gr, &err), CORE_OK);
    assert_non_null(gc.hairmesh);
    assert_ptr_not_equal(gc.hairmesh->pos, gr.hairmesh->pos);
    assert_memory_equal(gc.hairmesh->pos, gr.hairmesh->pos, 7 * 9 * sizeof(float));
    core_groom_free(&gc);
    core_groom_free(&gr);
    assert_null(gr.hairmesh);
    core_hairmesh_free(&c);
}

static void test_trace(void **state)
{
    (void)state;
    core_hairmesh m;
    small_mesh(&m);
    /* quad 0 at (u, v) = (0.25, 0.5): bilinear weights of corners 0, 1, 4, 3 */
    float out[3 * 5];
    const float t5[5] = { 0.0f, 0.5f, 1.0f, 1.5f, 2.0f };
    core_hairmesh_trace(&m, m.pos, 0, 0.25f, 0.5f, 5, t5, out);
    for (uint32_t i = 0; i < 5; i++) {
        float t = t5[i]; /* layer parameter */
        float ex = 0.01f * 0.25f + 0.005f * t, ey = 0.02f * t, ez = -0.01f * 0.5f;
        assert_float_equal(out[3 * i], ex, 1e-6);
        assert_float_equal(out[3 * i + 1], ey, 1e-6);
        assert_float_equal(out[3 * i + 2], ez, 1e-6);
    }
    /* the triangle (1, 0, 6) at barycentric (u, v) = (0.2, 0.3): corner 1 gets 0.5 */
    float w[4];
    core_hairmesh_weights(3, 0.2f, 0.3f, w);
    assert_float_equal(w[0], 0.5f, 1e-7);
    assert_float_equal(w[3], 0.0f, 0.0);
    const float t2[2] = { 0.0f, 2.0f };
    core_hairmesh_trace(&m, m.pos, 2, 0.2f, 0.3f, 2, t2, out);
    assert_float_equal(out[0], 0.5f * 0.01f + 0.2f * 0.0f + 0.3f * 0.01f, 1e-6);
    assert_float_equal(out[2], 0.3f * 0.01f, 1e-6);
    assert_float_equal(out[4], 0.04f, 1e-6); /* the tip layer */
    /* piecewise linear between the layer points: t = 2/3 is two thirds up the first layer segment */
    const float t4[4] = { 0.0f, 2.0f / 3.0f, 4.0f / 3.0f, 2.0f };
    core_hairmesh_trace(&m, m.pos, 0, 0.0f, 0.0f, 4, t4, out);
    assert_float_equal(out[4], 0.02f * 2.0f / 3.0f, 1e-6);
    core_hairmesh_weights(4, 1.0f, 1.0f, w);
    assert_float_equal(w[2], 1.0f, 0.0);
    core_hairmesh_free(&m);
}

static void test_procedural(void **state)
{
    (void)state;
    core_err err;
    const groom_style styles[3] = { GROOM_STRAIGHT, GROOM_WAVY, GROOM_CURLY };
    for (int s = 0; s < 3; s++) {
        core_hairmesh m;
        groom_hairmesh_desc d = { .style = styles[s] };
        assert_int_equal(groom_hairmesh_procedural(&d, &m, &err), CORE_OK);
        assert_int_equal(m.ncols, 9u * 9u);
        assert_int_equal(m.nlayers, GROOM_HAIRMESH_DEFAULT_LAYERS);
        assert_int_equal(m.nfaces, 9u * 4u);
        assert_int_equal(core_hairmesh_validate(&m, &err), CORE_OK);
        /* roots on the scalp (1 mm out), every vertex outside the head, the tips well below the roots */
        double root_y = 0.0, tip_y = 0.0, tet_pos = 0.0, tet_all = 0.0;
        for (uint32_t c = 0; c < m.ncols; c++) {
            for (uint32_t l = 0; l < m.nlayers; l++) {
                const float *p = m.pos + 3 * ((size_t)c * m.nlayers + l);
                double e = sqrt(pow(p[0] / GROOM_HEAD_RX, 2) + pow(p[1] / GROOM_HEAD_RY, 2) + pow(p[2] / GROOM_HEAD_RZ, 2));
                assert_true(e > 1.0);
                if (l == 0) assert_true(e < 1.02);
            }
            root_y += m.pos[3 * (size_t)c * m.nlayers + 1];
            tip_y += m.pos[3 * ((size_t)c * m.nlayers + m.nlayers - 1) + 1];
        }
        assert_true(tip_y / m.ncols < root_y / m.ncols - 0.1);
        /* the prisms point away from the scalp: the corner tetrahedra are (nearly all) positive */
        for (uint32_t f = 0; f < m.nfaces; f++)
            for (uint32_t l = 0; l + 1 < m.nlayers; l++)
                for (uint32_t k = 0; k < 4; k++) {
                    const uint32_t *c = m.faces + 4 * f;
                    const float *a = m.pos + 3 * (c[k] * m.nlayers + l), *b = m.pos + 3 * (c[(k + 1) % 4] * m.nlayers + l);
                    const float *p = m.pos + 3 * (c[(k + 3) % 4] * m.nlayers + l), *t = m.pos + 3 * (c[k] * m.nlayers + l + 1);
                    core_vec3 e1 = core_v3(b[0] - a[0], b[1] - a[1], b[2] - a[2]), e2 = core_v3(p[0] - a[0], p[1] - a[1], p[2] - a[2]);
                    core_vec3 e3 = core_v3(t[0] - a[0], t[1] - a[1], t[2] - a[2]);
                    double v = core_v3_dot(e1, core_v3_cross(e2, e3));
                    tet_all += fabs(v);
                    tet_pos += v > 0 ? v : 0;
                }
        assert_true(tet_pos > 0.98 * tet_all);
        core_hairmesh_free(&m);
    }
    /* sizes and refusals */
    core_hairmesh m;
    groom_hairmesh_desc d = { .patches = 1, .grid = 1, .nlayers = 2, .length = 0.05f };
    assert_int_equal(groom_hairmesh_procedural(&d, &m, &err), CORE_OK);
    assert_int_equal(m.ncols * m.nlayers, 8);
    core_hairmesh_free(&m);
    d.length = 3.0f;
    assert_int_equal(groom_hairmesh_procedural(&d, &m, &err), CORE_EINVAL);
    d.length = NAN;
    assert_int_equal(groom_hairmesh_procedural(&d, &m, &err), CORE_EINVAL);
    d.length = 0.1f, d.nlayers = CORE_HAIRMESH_MAX_LAYERS + 1;
    assert_int_equal(groom_hairmesh_procedural(&d, &m, &err), CORE_EINVAL);
    d.nlayers = 9, d.patches = 200, d.grid = 200;
    assert_int_equal(groom_hairmesh_procedural(&d, &m, &err), CORE_EINVAL);
    d.patches = 1, d.grid = 1, d.style = (groom_style)7;
    assert_int_equal(groom_hairmesh_procedural(&d, &m, &err), CORE_EINVAL);
    assert_int_equal(groom_hairmesh_procedural(NULL, &m, &err), CORE_OK);
    core_hairmesh_free(&m);
}

static void test_guides(void **state)
{
    (void)state;
    core_err err;
    core_hairmesh m;
    small_mesh(&m);
    core_groom g;
    assert_int_equal(groom_from_hairmesh(&m, 5, 7, &g, &err), CORE_OK);
    assert_int_equal(g.nstrands, 15);
    assert_int_equal(g.nverts, 7);
    assert_non_null(g.hairmesh);
    assert_int_equal(g.hairmesh->nguides, 15);
    assert_int_equal(core_hairmesh_validate(g.hairmesh, &err), CORE_OK);
    float out[3 * 7];
    for (uint32_t s = 0; s < 15; s++) {
        assert_int_equal(g.hairmesh->guide_face[s], s / 5);
        float t[7];
        core_hairmesh_even_params(&m, m.pos, s / 5, g.hairmesh->guide_uv[2 * s], g.hairmesh->guide_uv[2 * s + 1], 7, t);
        assert_memory_equal(t, g.hairmesh->guide_t + 7 * (size_t)s, sizeof t);
        core_hairmesh_trace(&m, m.pos, s / 5, g.hairmesh->guide_uv[2 * s], g.hairmesh->guide_uv[2 * s + 1], 7, t, out);
        assert_memory_equal(out, g.pos + 3 * 7 * (size_t)s, sizeof out);
    }
    /* the first strand of a quad sits at its centre */
    assert_float_equal(g.hairmesh->guide_uv[0], 0.5f, 0.0);
    assert_float_equal(g.hairmesh->guide_uv[1], 0.5f, 0.0);
    core_groom_free(&g);
    assert_int_equal(groom_from_hairmesh(&m, 0, 7, &g, &err), CORE_EINVAL);
    assert_int_equal(groom_from_hairmesh(&m, 1, 1, &g, &err), CORE_EINVAL);
    assert_int_equal(groom_from_hairmesh(&m, GROOM_MAX_STRANDS, 8, &g, &err), CORE_EINVAL);
    m.faces[0] = 99;
    assert_int_equal(groom_from_hairmesh(&m, 1, 8, &g, &err), CORE_EFORMAT);
    core_hairmesh_free(&m);
}

static core_status load_text(const char *s, core_hairmesh *m, core_err *err)
{
    return groom_hairmesh_load_obj(s, strlen(s), m, err);
}

/* The largest relative spread (max - min) / mean of a strand's segment lengths over g's strands. */
static double segment_spread(const core_groom *g)
{
    double worst = 0.0;
    for (uint32_t s = 0; s < g->nstrands; s++) {
        double lo = INFINITY, hi = 0.0, sum = 0.0;
        for (uint32_t i = 0; i + 1 < g->nverts; i++) {
            const float *a = g->pos + 3 * ((size_t)s * g->nverts + i), *b = a + 3;
            double d = sqrt(pow((double)b[0] - a[0], 2) + pow((double)b[1] - a[1], 2) + pow((double)b[2] - a[2], 2));
            lo = fmin(lo, d), hi = fmax(hi, d), sum += d;
        }
        worst = fmax(worst, (hi - lo) / (sum / (g->nverts - 1)));
    }
    return worst;
}

/* A quad (columns 0-3) and a triangle (1, 4, 2) over 5 layers at uneven heights (3 mm, then
 * 4.7 cm, 1 cm, 9 cm), bent along x: a layered .obj of the importer's convention. */
static char *uneven_obj(void)
{
    static const float roots[5][2] = { { 0, 0 }, { 0.02f, 0 }, { 0.02f, 0.02f }, { 0, 0.02f }, { 0.04f, 0.01f } };
    static const float height[5] = { 0.0f, 0.003f, 0.05f, 0.06f, 0.15f };
    size_t cap = 4096, n = 0;
    char *t = malloc(cap);
    assert_non_null(t);
    n += (size_t)snprintf(t + n, cap - n, "# uneven layers\n");
    for (int l = 0; l < 5; l++)
        for (int c = 0; c < 5; c++)
            n += (size_t)snprintf(t + n, cap - n, "v %g %g %g\n", (double)(roots[c][0] + 0.3f * height[l] * height[l] * 10.0f),
                                  (double)-height[l], (double)roots[c][1]);
    n += (size_t)snprintf(t + n, cap - n, "f 1 2 3 4\nf 2 5 3\n");
    assert_true(n < cap);
    return t;
}

static void test_even_segments(void **state)
{
    (void)state;
    core_err err;
    core_groom g;
    /* the procedural styles, whose first layer lies closer to the scalp than the others are apart */
    const groom_style styles[3] = { GROOM_STRAIGHT, GROOM_WAVY, GROOM_CURLY };
    for (int st = 0; st < 3; st++) {
        core_hairmesh m;
        groom_hairmesh_desc d = { .style = styles[st] };
        assert_int_equal(groom_hairmesh_procedural(&d, &m, &err), CORE_OK);
        const uint32_t nv[3] = { 5, 8, 24 };
        for (int k = 0; k < 3; k++) {
            assert_int_equal(groom_from_hairmesh(&m, 2, nv[k], &g, &err), CORE_OK);
            double spread = segment_spread(&g);
            if (!(spread <= 1e-3)) fail_msg("style %d, %u vertices: segment spread %g", st, nv[k], spread);
            assert_int_equal(core_hairmesh_validate(g.hairmesh, &err), CORE_OK);
            assert_int_equal(g.hairmesh->guide_nverts, nv[k]);
            core_groom_free(&g);
        }
        core_hairmesh_free(&m);
    }
    /* an imported mesh with very uneven layers, quads and a triangle */
    char *text = uneven_obj();
    core_hairmesh m;
    assert_int_equal(load_text(text, &m, &err), CORE_OK);
    free(text);
    const uint32_t nv[4] = { 3, 6, 17, 40 };
    for (int k = 0; k < 4; k++) {
        assert_int_equal(groom_from_hairmesh(&m, 7, nv[k], &g, &err), CORE_OK);
        double spread = segment_spread(&g);
        if (!(spread <= 1e-3)) fail_msg("obj mesh, %u vertices: segment spread %g", nv[k], spread);
        /* the root on the root layer, the tip on the tip layer */
        float t[40];
        core_hairmesh_even_params(&m, m.pos, 0, 0.5f, 0.5f, nv[k], t);
        assert_float_equal(t[0], 0.0f, 0.0);
        assert_float_equal(t[nv[k] - 1], 4.0f, 0.0);
        core_groom_free(&g);
    }
    /* straight strands: the middle vertex of 3 sits half way along (7.5 cm), a sixth of the way
     * from layer 3 (6 cm) to layer 4 (15 cm) */
    float t[3], out[9];
    for (uint32_t c = 0; c < 5; c++)
        for (uint32_t l = 0; l < 5; l++) m.pos[3 * (c * 5 + l)] = (float)c * 0.01f;
    core_hairmesh_even_params(&m, m.pos, 0, 0.0f, 0.0f, 3, t);
    assert_float_equal(t[1], 3.0f + (0.075f - 0.06f) / (0.15f - 0.06f), 1e-5);
    core_hairmesh_trace(&m, m.pos, 0, 0.0f, 0.0f, 3, t, out);
    assert_float_equal(out[4], -0.075f, 1e-6);
    /* a strand of zero length gets the uniform parameters */
    for (uint32_t i = 0; i < 3 * 25; i++) m.pos[i] = 0.0f;
    core_hairmesh_even_params(&m, m.pos, 1, 0.2f, 0.2f, 3, t);
    assert_float_equal(t[0], 0.0f, 0.0);
    assert_float_equal(t[1], 2.0f, 0.0);
    assert_float_equal(t[2], 4.0f, 0.0);
    core_hairmesh_free(&m);
}

static void test_obj_round_trip_and_example(void **state)
{
    (void)state;
    core_err err;
    core_hairmesh m, back;
    groom_hairmesh_desc d = { .patches = 2, .grid = 2, .nlayers = 5, .style = GROOM_WAVY };
    assert_int_equal(groom_hairmesh_procedural(&d, &m, &err), CORE_OK);
    char *text;
    size_t len;
    assert_int_equal(groom_hairmesh_write_obj(&m, &text, &len, &err), CORE_OK);
    assert_int_equal(strlen(text), len);
    assert_int_equal(groom_hairmesh_load_obj(text, len, &back, &err), CORE_OK);
    assert_int_equal(back.ncols, m.ncols);
    assert_int_equal(back.nlayers, m.nlayers);
    assert_int_equal(back.nfaces, m.nfaces);
    assert_memory_equal(back.pos, m.pos, (size_t)m.ncols * m.nlayers * 3 * sizeof(float));
    assert_memory_equal(back.faces, m.faces, (size_t)m.nfaces * 4 * sizeof(uint32_t));
    core_hairmesh_free(&back);
    /* the example file of the convention (README.md, "Hair meshes") */
    FILE *f = fopen("hairmesh_example.obj", "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, len, f), len);
    assert_int_equal(fclose(f), 0);
    /* a triangle root face, negative and slashed indices, comments and other statements */
    const char *tri = "# layers of 3\nv 0 0 0\nv 1 0 0\nv 0 0 -1\nvn 0 1 0\nv 0 1 0\nv 1 1 0\nv 0 1 -1\n"
                      "o hair\nf 1/1/1 2//1 -4\n";
    assert_int_equal(load_text(tri, &back, &err), CORE_OK);
    assert_int_equal(back.ncols, 3);
    assert_int_equal(back.nlayers, 2);
    assert_int_equal(back.faces[2], 2);
    assert_int_equal(back.faces[3], CORE_HAIRMESH_NONE);
    assert_float_equal(back.pos[3 * 1 + 1], 1.0f, 0.0); /* column 0, layer 1 */
    core_hairmesh_free(&back);
    free(text);
    core_hairmesh_free(&m);
}

static void expect_error(const char *s, const char *what)
{
    core_err err;
    core_hairmesh m;
    memset(&m, 0xab, sizeof m);
    core_status st = load_text(s, &m, &err);
    if (st != CORE_EFORMAT) fail_msg("expected a format error for %s, got %d", what, (int)st);
    if (!strstr(err.msg, what)) fail_msg("'%s' does not mention '%s'", err.msg, what);
    assert_null(m.pos);
}

static void test_obj_malformed(void **state)
{
    (void)state;
    const char *layers = "v 0 0 0\nv 1 0 0\nv 0 0 -1\nv 0 1 0\nv 1 1 0\nv 0 1 -1\n";
    char buf[512];
    expect_error("", "no hair mesh");
    expect_error(layers, "no hair mesh");
    snprintf(buf, sizeof buf, "%sf 1 2\n", layers);
    expect_error(buf, "3 or 4 vertices");
    snprintf(buf, sizeof buf, "%sf 1 2 3 1 2\n", layers);
    expect_error(buf, "3 or 4 vertices");
    snprintf(buf, sizeof buf, "%sf 1 2 0\n", layers);
    expect_error(buf, "out of range");
    snprintf(buf, sizeof buf, "%sf 1 2 9\n", layers);
    expect_error(buf, "out of range");
    snprintf(buf, sizeof buf, "%sf 1 2 -7\n", layers);
    expect_error(buf, "out of range");
    snprintf(buf, sizeof buf, "%sf 1 2 x\n", layers);
    expect_error(buf, "bad face vertex");
    snprintf(buf, sizeof buf, "%sf 1 2 3a\n", layers);
    expect_error(buf, "bad face vertex");
    snprintf(buf, sizeof buf, "%sf 1 2 99999999999999999999999\n", layers);
    expect_error(buf, "bad face vertex");
    snprintf(buf, sizeof buf, "%sf 1 2 4\n", layers); /* a face reaching into layer 1: 4 columns, 6 vertices */
    expect_error(buf, "whole layers");
    snprintf(buf, sizeof buf, "%sv 2 2 2\nf 1 2 3\n", layers);
    expect_error(buf, "whole layers");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 0 -1\nf 1 2 3\n", "whole layers");
    expect_error("v 0 0\n", "3 numbers");
    expect_error("v 0 0 nan\n", "not finite");
    expect_error("v 0 0 1e30\n", "not finite or beyond");
    expect_error("v 0 0 0x\n", "3 numbers");
    expect_error("v 0 0 0\n\x01\n", "binary data");
    snprintf(buf, sizeof buf, "%sf 1 3 3\n", layers);
    expect_error(buf, "twice");
    char *long_line = malloc(GROOM_MESH_MAX_LINE + 16);
    memset(long_line, ' ', GROOM_MESH_MAX_LINE + 8);
    long_line[GROOM_MESH_MAX_LINE + 8] = '\0';
    expect_error(long_line, "longer than");
    free(long_line);
    core_err err;
    core_hairmesh m;
    assert_int_equal(groom_hairmesh_load_obj(NULL, 10, &m, &err), CORE_EFORMAT);
}

/* Every prefix of a valid file, and 3,000 files with random bytes changed, inserted or removed,
 * load or fail with a format error; the loaded ones are valid (ASan checks the bounds). */
static void test_obj_hostile(void **state)
{
    (void)state;
    core_err err;
    core_hairmesh m;
    groom_hairmesh_desc d = { .patches = 1, .grid = 2, .nlayers = 3 };
    assert_int_equal(groom_hairmesh_procedural(&d, &m, &err), CORE_OK);
    char *text;
    size_t len;
    assert_int_equal(groom_hairmesh_write_obj(&m, &text, &len, &err), CORE_OK);
    core_hairmesh_free(&m);
    int ok = 0;
    for (size_t n = 0; n <= len; n++) {
        char *copy = malloc(n ? n : 1); /* exactly n bytes, no terminator */
        memcpy(copy, text, n);
        core_status st = groom_hairmesh_load_obj(copy, n, &m, &err);
        assert_true(st == CORE_OK || st == CORE_EFORMAT);
        if (st == CORE_OK) {
            assert_int_equal(core_hairmesh_validate(&m, &err), CORE_OK);
            core_hairmesh_free(&m);
            ok++;
        }
        free(copy);
    }
    assert_true(ok >= 1);
    uint64_t seed = 0x9e3779b97f4a7c15ull;
    const char alphabet[] = "0123456789 -./\nvf#e+\r\t\x01nai";
    for (int trial = 0; trial < 3000; trial++) {
        char *copy = malloc(len + 8);
        size_t n = len;
        memcpy(copy, text, len);
        for (int k = 0; k < 1 + trial % 4; k++) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            size_t at = (size_t)(seed >> 33) % n;
            char ch = alphabet[(seed >> 20) % (sizeof alphabet - 1)];
            int op = (int)((seed >> 10) % 3);
            if (op == 0) copy[at] = ch;
            else if (op == 1 && n < len + 8) memmove(copy + at + 1, copy + at, n - at), copy[at] = ch, n++;
            else if (n > 1) memmove(copy + at, copy + at + 1, n - at - 1), n--;
        }
        core_status st = groom_hairmesh_load_obj(copy, n, &m, &err);
        assert_true(st == CORE_OK || st == CORE_EFORMAT);
        if (st == CORE_OK) {
            assert_int_equal(core_hairmesh_validate(&m, &err), CORE_OK);
            core_hairmesh_free(&m);
        }
        free(copy);
    }
    free(text);
}

/* groom_load_file on a .hairmesh.obj: the guides traced through the layered mesh, whole strands
 * per face and GROOM_DEFAULT_STRANDS or a little more, the asked vertex count; a collision-mesh
 * .obj under that name (one layer) is refused naming the file. */
static void test_load_file_hairmesh(void **state)
{
    (void)state;
    char dir[] = "/tmp/test_hairmesh_XXXXXX", path[64];
    assert_non_null(mkdtemp(dir));
    core_err err;
    core_hairmesh m;
    groom_hairmesh_desc d = { .patches = 2, .nlayers = 4 };
    assert_int_equal(groom_hairmesh_procedural(&d, &m, &err), CORE_OK);
    char *text;
    size_t len;
    assert_int_equal(groom_hairmesh_write_obj(&m, &text, &len, &err), CORE_OK);
    snprintf(path, sizeof path, "%s/a.hairmesh.obj", dir);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, len, f), len);
    fclose(f);
    free(text);
    core_groom g;
    if (groom_load_file(path, 9, &g, &err) != CORE_OK) fail_msg("%s", err.msg);
    assert_non_null(g.hairmesh);
    assert_int_equal(g.hairmesh->ncols, m.ncols);
    assert_int_equal(g.hairmesh->nlayers, m.nlayers);
    assert_int_equal(g.hairmesh->nguides, g.nstrands);
    assert_int_equal(g.nverts, 9);
    assert_true(g.nstrands >= GROOM_DEFAULT_STRANDS && g.nstrands < GROOM_DEFAULT_STRANDS + m.nfaces);
    assert_int_equal(g.nstrands % m.nfaces, 0);
    core_groom_free(&g);
    core_hairmesh_free(&m);
    f = fopen(path, "wb");
    assert_non_null(f);
    fputs("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n", f);
    fclose(f);
    assert_int_not_equal(groom_load_file(path, 0, &g, &err), CORE_OK);
    assert_non_null(strstr(err.msg, "a.hairmesh.obj"));
    assert_int_equal(unlink(path), 0);
    assert_int_equal(rmdir(dir), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_alloc_validate_copy),
        cmocka_unit_test(test_trace),
        cmocka_unit_test(test_procedural),
        cmocka_unit_test(test_guides),
        cmocka_unit_test(test_even_segments),
        cmocka_unit_test(test_obj_round_trip_and_example),
        cmocka_unit_test(test_obj_malformed),
        cmocka_unit_test(test_obj_hostile),
        cmocka_unit_test(test_load_file_hairmesh),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
