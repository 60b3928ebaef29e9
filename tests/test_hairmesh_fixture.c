/* The hair mesh tracing fixture tests/js/hairmesh_trace.json: strands traced by the C rule
 * (core_hairmesh_trace) through a procedural curly hair mesh and a hand-made mesh of a quad and
 * a triangle, at several vertex counts, which tests/js/hairmesh.test.mjs checks web/hairmesh.js
 * (the viewer's vertex shader math) against. This test makes the fixture again and requires the
 * stored bytes (STRANDCAST_WRITE_VECTORS=1 writes it instead). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "core/hairmesh_types.h"
#include "groom/groom.h"

/* A growable text buffer. */
typedef struct text {
    char *p;
    size_t n, cap;
} text;

static void put(text *t, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int w = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    assert_true(w >= 0);
    if (t->n + (size_t)w + 1 > t->cap) {
        t->cap = (t->n + (size_t)w + 1) * 2;
        t->p = realloc(t->p, t->cap);
        assert_non_null(t->p);
    }
    va_start(ap, fmt);
    vsnprintf(t->p + t->n, t->cap - t->n, fmt, ap);
    va_end(ap);
    t->n += (size_t)w;
}

static void put_floats(text *t, const float *v, size_t n)
{
    put(t, "[");
    for (size_t i = 0; i < n; i++) put(t, "%s%.9g", i ? ", " : "", (double)v[i]);
    put(t, "]");
}

/* One mesh and the strands traced through it: (face, u, v) at 2, nlayers and 3 nlayers - 1
 * vertices. */
static void put_mesh(text *t, const char *name, const core_hairmesh *m, const float (*cases)[3], size_t ncases, bool last)
{
    put(t, "    {\"name\": \"%s\", \"ncols\": %u, \"nlayers\": %u, \"nfaces\": %u,\n     \"faces\": [", name, m->ncols,
        m->nlayers, m->nfaces);
    for (size_t i = 0; i < 4u * m->nfaces; i++)
        put(t, "%s%u", i ? ", " : "", m->faces[i] == CORE_HAIRMESH_NONE ? 4294967295u : m->faces[i]);
    put(t, "],\n     \"pos\": ");
    put_floats(t, m->pos, 3u * (size_t)m->ncols * m->nlayers);
    put(t, ",\n     \"strands\": [\n");
    const uint32_t counts[3] = { 2, m->nlayers, 3 * m->nlayers - 1 };
    for (size_t c = 0; c < ncases; c++)
        for (int k = 0; k < 3; k++) {
            uint32_t nv = counts[k];
            float *out = malloc(3u * nv * sizeof *out);
            assert_non_null(out);
            core_hairmesh_trace(m, m->pos, (uint32_t)cases[c][0], cases[c][1], cases[c][2], nv, out);
            put(t, "       {\"face\": %u, \"u\": %.9g, \"v\": %.9g, \"nverts\": %u, \"xyz\": ", (uint32_t)cases[c][0],
                (double)cases[c][1], (double)cases[c][2], nv);
            put_floats(t, out, 3u * nv);
            put(t, "}%s\n", c + 1 == ncases && k == 2 ? "" : ",");
            free(out);
        }
    put(t, "     ]}%s\n", last ? "" : ",");
}

static void test_trace_fixture(void **state)
{
    (void)state;
    core_err err;
    core_hairmesh curly;
    groom_hairmesh_desc d = { .style = GROOM_CURLY, .grid = 2, .nlayers = 6 };
    assert_int_equal(groom_hairmesh_procedural(&d, &curly, &err), CORE_OK);
    assert_int_equal(core_hairmesh_validate(&curly, &err), CORE_OK);
    static const float curly_cases[][3] = { { 0, 0.25f, 0.75f }, { 3, 0.9f, 0.1f }, { 1, 0.5f, 0.5f } };
    /* a quad (0 1 2 3) and a triangle (1 4 2) over 3 layers, bent */
    static uint32_t faces[8] = { 0, 1, 2, 3, 1, 4, 2, CORE_HAIRMESH_NONE };
    float pos[5 * 3 * 3];
    static const float roots[5][3] = { { 0, 0, 0 }, { 0.02f, 0, 0 }, { 0.02f, 0, 0.02f }, { 0, 0, 0.02f }, { 0.04f, 0, 0.01f } };
    for (int c = 0; c < 5; c++)
        for (int l = 0; l < 3; l++) {
            float *p = pos + 3 * (c * 3 + l);
            p[0] = roots[c][0] + 0.004f * (float)(l * l);
            p[1] = roots[c][1] - 0.05f * (float)l;
            p[2] = roots[c][2] + 0.001f * (float)(c * l);
        }
    core_hairmesh hand = { .ncols = 5, .nlayers = 3, .pos = pos, .nfaces = 2, .faces = faces };
    assert_int_equal(core_hairmesh_validate(&hand, &err), CORE_OK);
    static const float hand_cases[][3] = { { 0, 0.3f, 0.6f }, { 1, 0.2f, 0.3f }, { 1, 0.0f, 1.0f } };
    text t = { 0 };
    put(&t, "{\n  \"rule\": \"core_hairmesh_trace (server/core/hairmesh_types.h)\",\n  \"meshes\": [\n");
    put_mesh(&t, "procedural_curly", &curly, curly_cases, 3, false);
    put_mesh(&t, "hand_quad_triangle", &hand, hand_cases, 3, true);
    put(&t, "  ]\n}\n");
    core_hairmesh_free(&curly);

    const char *src = getenv("STRANDCAST_SOURCE_DIR"), *w = getenv("STRANDCAST_WRITE_VECTORS");
    char path[1024];
    snprintf(path, sizeof path, "%s/tests/js/hairmesh_trace.json", src ? src : STRANDCAST_SOURCE_DIR);
    if (w && strcmp(w, "1") == 0) {
        FILE *fp = fopen(path, "wb");
        assert_non_null(fp);
        assert_true(fwrite(t.p, 1, t.n, fp) == t.n);
        fclose(fp);
    } else {
        FILE *fp = fopen(path, "rb");
        if (!fp) fail_msg("cannot open %s (run with STRANDCAST_WRITE_VECTORS=1 to make it)", path);
        char *have = malloc(t.n + 1);
        assert_non_null(have);
        size_t got = fread(have, 1, t.n + 1, fp);
        fclose(fp);
        if (got != t.n || memcmp(have, t.p, t.n) != 0) fail_msg("%s differs from what core_hairmesh_trace gives now", path);
        free(have);
    }
    free(t.p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_trace_fixture),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
