/* The hair mesh tracing fixture tests/js/hairmesh_trace.json: strands traced by the C rule
 * (core_hairmesh_trace at the even layer parameters of core_hairmesh_even_params) through a
 * procedural curly hair mesh and a hand-made mesh of a quad and a triangle with uneven layers,
 * at several vertex counts, which tests/js/hairmesh.test.mjs checks web/hairmesh.js (the
 * viewer's vertex shader math) against. This test computes every stored strand's parameters and
 * traces it through its stored mesh again and requires the stored values bit for bit, so the C
 * rule and the fixture cannot drift apart (a change of the procedural generator does not matter);
 * STRANDCAST_WRITE_VECTORS=1 makes the fixture afresh instead. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cjson/cJSON.h>
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
            float *out = malloc(3u * nv * sizeof *out), *lt = malloc(nv * sizeof *lt);
            assert_true(out && lt);
            core_hairmesh_even_params(m, m->pos, (uint32_t)cases[c][0], cases[c][1], cases[c][2], nv, lt);
            core_hairmesh_trace(m, m->pos, (uint32_t)cases[c][0], cases[c][1], cases[c][2], nv, lt, out);
            put(t, "       {\"face\": %u, \"u\": %.9g, \"v\": %.9g, \"nverts\": %u, \"t\": ", (uint32_t)cases[c][0],
                (double)cases[c][1], (double)cases[c][2], nv);
            put_floats(t, lt, nv);
            put(t, ",\n        \"xyz\": ");
            put_floats(t, out, 3u * nv);
            put(t, "}%s\n", c + 1 == ncases && k == 2 ? "" : ",");
            free(out);
            free(lt);
        }
    put(t, "     ]}%s\n", last ? "" : ",");
}

/* The floats of a JSON array of numbers (n of them, or fails). */
static void floats_of(const cJSON *a, float *out, size_t n)
{
    assert_true(cJSON_IsArray(a) && (size_t)cJSON_GetArraySize(a) == n);
    size_t i = 0;
    for (const cJSON *c = a->child; c; c = c->next) out[i++] = (float)c->valuedouble;
}

/* Traces every strand of the stored fixture text through its stored mesh: the coordinates must
 * be the stored ones exactly (they are printed with 9 significant digits: float32 round trips). */
static void check_fixture(const char *text)
{
    cJSON *root = cJSON_Parse(text);
    assert_non_null(root);
    const cJSON *meshes = cJSON_GetObjectItemCaseSensitive(root, "meshes");
    int nmesh = 0, nstrands = 0;
    for (const cJSON *m = meshes ? meshes->child : NULL; m; m = m->next, nmesh++) {
        core_hairmesh h = { .ncols = (uint32_t)cJSON_GetObjectItemCaseSensitive(m, "ncols")->valuedouble,
                            .nlayers = (uint32_t)cJSON_GetObjectItemCaseSensitive(m, "nlayers")->valuedouble,
                            .nfaces = (uint32_t)cJSON_GetObjectItemCaseSensitive(m, "nfaces")->valuedouble };
        size_t np = 3u * (size_t)h.ncols * h.nlayers;
        h.pos = malloc(np * sizeof *h.pos);
        h.faces = malloc(4u * h.nfaces * sizeof *h.faces);
        assert_true(h.pos && h.faces);
        floats_of(cJSON_GetObjectItemCaseSensitive(m, "pos"), h.pos, np);
        const cJSON *faces = cJSON_GetObjectItemCaseSensitive(m, "faces");
        assert_int_equal(cJSON_GetArraySize(faces), 4 * (int)h.nfaces);
        size_t i = 0;
        for (const cJSON *c = faces->child; c; c = c->next) h.faces[i++] = (uint32_t)c->valuedouble;
        core_err err;
        assert_int_equal(core_hairmesh_validate(&h, &err), CORE_OK);
        for (const cJSON *s = cJSON_GetObjectItemCaseSensitive(m, "strands")->child; s; s = s->next, nstrands++) {
            uint32_t nv = (uint32_t)cJSON_GetObjectItemCaseSensitive(s, "nverts")->valuedouble;
            float *want = malloc(3u * nv * sizeof *want), *got = malloc(3u * nv * sizeof *got);
            float *want_t = malloc(nv * sizeof *want_t), *got_t = malloc(nv * sizeof *got_t);
            assert_true(want && got && want_t && got_t);
            floats_of(cJSON_GetObjectItemCaseSensitive(s, "t"), want_t, nv);
            floats_of(cJSON_GetObjectItemCaseSensitive(s, "xyz"), want, 3u * nv);
            const uint32_t face = (uint32_t)cJSON_GetObjectItemCaseSensitive(s, "face")->valuedouble;
            const float u = (float)cJSON_GetObjectItemCaseSensitive(s, "u")->valuedouble;
            const float v = (float)cJSON_GetObjectItemCaseSensitive(s, "v")->valuedouble;
            core_hairmesh_even_params(&h, h.pos, face, u, v, nv, got_t);
            if (memcmp(want_t, got_t, nv * sizeof *got_t) != 0)
                fail_msg("strand %d of mesh %d: layer parameters are not what core_hairmesh_even_params gives now", nstrands,
                         nmesh);
            core_hairmesh_trace(&h, h.pos, face, u, v, nv, got_t, got);
            if (memcmp(want, got, 3u * nv * sizeof *got) != 0)
                fail_msg("strand %d of mesh %d is not what core_hairmesh_trace gives now", nstrands, nmesh);
            free(want);
            free(got);
            free(want_t);
            free(got_t);
        }
        free(h.pos);
        free(h.faces);
    }
    assert_true(nmesh == 2 && nstrands >= 18);
    cJSON_Delete(root);
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
    /* a quad (0 1 2 3) and a triangle (1 4 2) over 3 layers 1 cm and 5 cm apart, bent */
    static const float heights[3] = { 0.0f, 0.01f, 0.06f };
    static uint32_t faces[8] = { 0, 1, 2, 3, 1, 4, 2, CORE_HAIRMESH_NONE };
    float pos[5 * 3 * 3];
    static const float roots[5][3] = { { 0, 0, 0 }, { 0.02f, 0, 0 }, { 0.02f, 0, 0.02f }, { 0, 0, 0.02f }, { 0.04f, 0, 0.01f } };
    for (int c = 0; c < 5; c++)
        for (int l = 0; l < 3; l++) {
            float *p = pos + 3 * (c * 3 + l);
            p[0] = roots[c][0] + 0.004f * (float)(l * l);
            p[1] = roots[c][1] - heights[l];
            p[2] = roots[c][2] + 0.001f * (float)(c * l);
        }
    core_hairmesh hand = { .ncols = 5, .nlayers = 3, .pos = pos, .nfaces = 2, .faces = faces };
    assert_int_equal(core_hairmesh_validate(&hand, &err), CORE_OK);
    static const float hand_cases[][3] = { { 0, 0.3f, 0.6f }, { 1, 0.2f, 0.3f }, { 1, 0.0f, 1.0f } };
    text t = { 0 };
    put(&t, "{\n  \"rule\": \"core_hairmesh_even_params, core_hairmesh_trace (server/core/hairmesh_types.h)\",\n  \"meshes\": [\n");
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
        char *have = malloc(1u << 20);
        assert_non_null(have);
        size_t got = fread(have, 1, (1u << 20) - 1, fp);
        fclose(fp);
        have[got] = '\0';
        check_fixture(have);
        free(have);
    }
    check_fixture(t.p); /* what it writes passes too */
    free(t.p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_trace_fixture),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
