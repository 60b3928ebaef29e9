/* tests: procedural grooms, .tfx / .hair loaders (valid, broken, truncated, fuzzed), resampling, colliders. */
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
#include "sim/sim.h"
#include "support/sim_check.h"

/* ---- helpers ------------------------------------------------------------------------- */

static core_vec3 vtx(const core_groom *g, uint32_t s, uint32_t v)
{
    const float *p = g->pos + ((size_t)s * g->nverts + v) * 3;
    return core_v3(p[0], p[1], p[2]);
}

static float head_f(core_vec3 p)
{
    float x = p.x / GROOM_HEAD_RX, y = p.y / GROOM_HEAD_RY, z = p.z / GROOM_HEAD_RZ;
    return x * x + y * y + z * z;
}

static float seg_dist(core_vec3 a, core_vec3 b, core_vec3 p)
{
    core_vec3 ab = core_v3_sub(b, a);
    float t = core_v3_dot(core_v3_sub(p, a), ab) / core_v3_dot(ab, ab);
    t = t < 0.0f ? 0.0f : t > 1.0f ? 1.0f : t;
    return core_v3_len(core_v3_sub(p, core_v3_add(a, core_v3_scale(ab, t))));
}

/* Independent inside test (no margin). */
static int inside(const core_collider *c, core_vec3 p)
{
    switch (c->kind) {
    case CORE_COLLIDER_SPHERE: return core_v3_len(core_v3_sub(p, c->a)) < c->radius;
    case CORE_COLLIDER_CAPSULE: return seg_dist(c->a, c->b, p) < c->radius;
    case CORE_COLLIDER_ELLIPSOID: {
        core_vec3 l = core_q_rotate(core_q_conj(c->rot), core_v3_sub(p, c->a));
        float x = l.x / c->radii.x, y = l.y / c->radii.y, z = l.z / c->radii.z;
        return x * x + y * y + z * z < 1.0f;
    }
    }
    return 1;
}

static uint64_t rng_state(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static void put_u32(unsigned char *b, size_t off, uint32_t v)
{
    for (int i = 0; i < 4; i++) b[off + i] = (unsigned char)(v >> (8 * i));
}

static void put_f32(unsigned char *b, size_t off, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put_u32(b, off, u);
}

static void put_u16(unsigned char *b, size_t off, uint16_t v)
{
    b[off] = (unsigned char)v;
    b[off + 1] = (unsigned char)(v >> 8);
}

/* Point v of fixture strand s: a straight line from (s, 1, 0) stepping 0.01 along (1, -2, 0.5)/|..|. */
static core_vec3 line_point(uint32_t s, float t)
{
    core_vec3 d = core_v3_norm(core_v3(1.0f, -2.0f, 0.5f));
    return core_v3_add(core_v3(0.1f * (float)s, 1.0f, 0.0f), core_v3_scale(d, t));
}

/* A valid .tfx image: ns strands x nv vertices on straight lines, uniform spacing 0.01, strand UVs at the end. */
static unsigned char *make_tfx(uint32_t ns, uint32_t nv, size_t *size)
{
    size_t pos = 160, uv = pos + (size_t)ns * nv * 16;
    *size = uv + (size_t)ns * 8;
    unsigned char *b = calloc(1, *size);
    put_f32(b, 0, 4.0f);
    put_u32(b, 4, ns);
    put_u32(b, 8, nv);
    put_u32(b, 12, (uint32_t)pos);
    put_u32(b, 16, (uint32_t)uv);
    for (uint32_t s = 0; s < ns; s++) {
        for (uint32_t v = 0; v < nv; v++) {
            core_vec3 p = line_point(s, 0.01f * (float)v);
            size_t at = pos + ((size_t)s * nv + v) * 16;
            put_f32(b, at, p.x);
            put_f32(b, at + 4, p.y);
            put_f32(b, at + 8, p.z);
            put_f32(b, at + 12, v == 0 ? 0.0f : 1.0f);
        }
        put_f32(b, uv + 8 * (size_t)s, 0.5f);
    }
    return b;
}

#define HAIR_ALL 31u

/* A valid .hair image with the given flags; strand s has counts[s] points (segments array
 * when flags & 1, else every strand has counts[0] points and d_segments = counts[0] - 1). */
static unsigned char *make_hair(uint32_t nh, const uint32_t *counts, uint32_t flags, size_t *size)
{
    uint32_t np = 0;
    for (uint32_t s = 0; s < nh; s++) np += (flags & 1) ? counts[s] : counts[0];
    size_t segs = (flags & 1) ? 2 * (size_t)nh : 0;
    size_t pts = 128 + segs;
    *size = pts + (size_t)np * 12 + ((flags & 4) ? np * 4u : 0) + ((flags & 8) ? np * 4u : 0) +
            ((flags & 16) ? np * 12u : 0);
    unsigned char *b = calloc(1, *size);
    memcpy(b, "HAIR", 4);
    put_u32(b, 4, nh);
    put_u32(b, 8, np);
    put_u32(b, 12, flags);
    put_u32(b, 16, counts[0] - 1);
    put_f32(b, 20, 1.0f);
    memcpy(b + 40, "strandcast test fixture", 23);
    size_t at = pts;
    for (uint32_t s = 0; s < nh; s++) {
        uint32_t n = (flags & 1) ? counts[s] : counts[0];
        if (flags & 1) put_u16(b, 128 + 2 * (size_t)s, (uint16_t)(n - 1));
        for (uint32_t v = 0; v < n; v++, at += 12) {
            core_vec3 p = line_point(s, 0.01f * (float)v);
            put_f32(b, at, p.x);
            put_f32(b, at + 4, p.y);
            put_f32(b, at + 8, p.z);
        }
    }
    for (size_t o = at; o + 4 <= *size; o += 4) put_f32(b, o, 0.25f); /* thickness, transparency, colours */
    return b;
}

static void assert_finite(const core_groom *g)
{
    for (size_t i = 0; i < (size_t)g->nstrands * g->nverts * 3; i++) assert_true(isfinite(g->pos[i]));
}

/* ---- procedural ---------------------------------------------------------------------- */

static void test_procedural_counts_determinism(void **state)
{
    (void)state;
    core_err e;
    core_groom a, b, c, d;
    groom_desc desc = { .style = GROOM_WAVY, .nstrands = 300, .nverts = 16, .seed = 7 };
    assert_int_equal(groom_procedural(&desc, &a, &e), CORE_OK);
    assert_int_equal(groom_procedural(&desc, &b, &e), CORE_OK);
    assert_int_equal(a.nstrands, 300);
    assert_int_equal(a.nverts, 16);
    assert_memory_equal(a.pos, b.pos, (size_t)300 * 16 * 3 * sizeof(float));
    desc.seed = 8;
    assert_int_equal(groom_procedural(&desc, &c, &e), CORE_OK);
    assert_true(memcmp(a.pos, c.pos, (size_t)300 * 16 * 3 * sizeof(float)) != 0);
    assert_int_equal(groom_procedural(NULL, &d, &e), CORE_OK);
    assert_int_equal(d.nstrands, GROOM_DEFAULT_STRANDS);
    assert_int_equal(d.nverts, GROOM_DEFAULT_VERTS);
    assert_int_equal(d.ncolliders, 4);
    assert_int_equal(d.colliders[0].kind, CORE_COLLIDER_ELLIPSOID);
    assert_finite(&d);
    core_groom_free(&a);
    core_groom_free(&b);
    core_groom_free(&c);
    core_groom_free(&d);
}

static void test_procedural_roots_on_scalp(void **state)
{
    (void)state;
    for (int style = 0; style < 3; style++) {
        core_err e;
        core_groom g;
        groom_desc desc = { .style = (groom_style)style, .nstrands = 2000, .nverts = 24, .seed = 11 };
        assert_int_equal(groom_procedural(&desc, &g, &e), CORE_OK);
        for (uint32_t s = 0; s < g.nstrands; s++) {
            core_vec3 r = vtx(&g, s, 0);
            float f = head_f(r);
            assert_true(f > 1.0f);
            core_vec3 surf = core_v3_scale(r, 1.0f / sqrtf(f));
            assert_true(core_v3_len(core_v3_sub(r, surf)) < 0.003f);
            core_vec3 u = core_v3_norm(core_v3(r.x / GROOM_HEAD_RX, r.y / GROOM_HEAD_RY, r.z / GROOM_HEAD_RZ));
            assert_true(u.y > -0.4f);                  /* scalp, not the chin or throat */
            assert_false(u.z > 0.5f && u.y < 0.45f);   /* not the face */
        }
        core_groom_free(&g);
    }
}

static void test_procedural_outside_colliders(void **state)
{
    (void)state;
    static const uint32_t nvs[] = { 2, 5, 32, 64 };
    for (int style = 0; style < 3; style++) {
        for (size_t k = 0; k < sizeof nvs / sizeof nvs[0]; k++) {
            for (uint64_t seed = 1; seed <= 2; seed++) {
                core_err e;
                core_groom g;
                groom_desc desc = { .style = (groom_style)style, .nstrands = 1500, .nverts = nvs[k], .seed = seed,
                                    .length = seed == 2 ? 0.5f : 0.0f };
                assert_int_equal(groom_procedural(&desc, &g, &e), CORE_OK);
                assert_int_equal(g.ncolliders, 4);
                for (uint32_t s = 0; s < g.nstrands; s++)
                    for (uint32_t v = 0; v < g.nverts; v++)
                        for (uint32_t c = 0; c < g.ncolliders; c++) {
                            if (inside(&g.colliders[c], vtx(&g, s, v)))
                                fail_msg("style %d nverts %u: strand %u vertex %u inside collider %u", style, g.nverts,
                                         s, v, c);
                        }
                core_groom_free(&g);
            }
        }
    }
}

static void test_procedural_segment_lengths(void **state)
{
    (void)state;
    for (int style = 0; style < 3; style++) {
        core_err e;
        core_groom g;
        groom_desc desc = { .style = (groom_style)style, .nstrands = 1000, .nverts = 32, .seed = 3, .length = 0.3f };
        assert_int_equal(groom_procedural(&desc, &g, &e), CORE_OK);
        for (uint32_t s = 0; s < g.nstrands; s++) {
            float l0 = core_v3_len(core_v3_sub(vtx(&g, s, 1), vtx(&g, s, 0))), total = 0.0f;
            for (uint32_t v = 1; v < g.nverts; v++) {
                float l = core_v3_len(core_v3_sub(vtx(&g, s, v), vtx(&g, s, v - 1)));
                assert_true(fabsf(l - l0) <= 1e-4f * l0);
                total += l;
            }
            assert_true(total > 0.3f * 0.9f && total < 0.3f * 1.1f);
        }
        core_groom_free(&g);
    }
}

/* Mean over strands of the summed turning angle between consecutive segments; *max gets the largest. */
static double mean_turning(const core_groom *g, double *max)
{
    double sum = 0.0;
    *max = 0.0;
    for (uint32_t s = 0; s < g->nstrands; s++) {
        for (uint32_t v = 1; v + 1 < g->nverts; v++) {
            core_vec3 a = core_v3_norm(core_v3_sub(vtx(g, s, v), vtx(g, s, v - 1)));
            core_vec3 b = core_v3_norm(core_v3_sub(vtx(g, s, v + 1), vtx(g, s, v)));
            float d = core_v3_dot(a, b);
            double ang = acos(d > 1.0f ? 1.0 : d < -1.0f ? -1.0 : (double)d);
            sum += ang;
            if (ang > *max) *max = ang;
        }
    }
    return sum / g->nstrands;
}

static void test_procedural_styles_differ(void **state)
{
    (void)state;
    double turn[3], kink[3];
    for (int style = 0; style < 3; style++) {
        core_err e;
        core_groom g;
        groom_desc desc = { .style = (groom_style)style, .nstrands = 500, .nverts = 48, .seed = 5 };
        assert_int_equal(groom_procedural(&desc, &g, &e), CORE_OK);
        turn[style] = mean_turning(&g, &kink[style]);
        core_groom_free(&g);
    }
    assert_true(turn[GROOM_WAVY] > 1.3 * turn[GROOM_STRAIGHT]);
    assert_true(turn[GROOM_CURLY] > 2.0 * turn[GROOM_STRAIGHT]);
    assert_true(turn[GROOM_CURLY] > turn[GROOM_WAVY]);
    /* straight and wavy strands bend smoothly (no kinks at the root or where they drape) */
    assert_true(kink[GROOM_STRAIGHT] < 1.2217 /* 70 degrees */);
    assert_true(kink[GROOM_WAVY] < 1.2217 /* 70 degrees */);
}

static void test_procedural_bad_desc(void **state)
{
    (void)state;
    static const struct {
        groom_desc d;
        const char *word;
    } cases[] = {
        { { .nverts = 1 }, "vertices" },
        { { .nverts = GROOM_MAX_VERTS + 1 }, "vertices" },
        { { .nstrands = GROOM_MAX_STRANDS + 1 }, "strands" },
        { { .nstrands = GROOM_MAX_STRANDS, .nverts = 64 }, "limit" },
        { { .length = -1.0f }, "length" },
        { { .length = 3.0f }, "length" },
        { { .length = NAN }, "length" },
        { { .length = INFINITY }, "length" },
        { { .style = (groom_style)7 }, "style" },
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        core_err e = { { 0 } };
        core_groom g;
        assert_int_equal(groom_procedural(&cases[i].d, &g, &e), CORE_EINVAL);
        assert_non_null(strstr(e.msg, cases[i].word));
        assert_null(g.pos);
    }
}

static void test_style_names(void **state)
{
    (void)state;
    core_err e;
    groom_style s;
    for (int i = 0; i < 3; i++) {
        assert_int_equal(groom_style_parse(groom_style_name((groom_style)i), &s, &e), CORE_OK);
        assert_int_equal(s, i);
    }
    assert_string_equal(groom_style_name(GROOM_CURLY), "curly");
    assert_int_equal(groom_style_parse("Curly", &s, &e), CORE_EINVAL);
    assert_non_null(strstr(e.msg, "straight, wavy or curly"));
    assert_int_equal(groom_style_parse(NULL, &s, &e), CORE_EINVAL);
}

/* ---- resampling ---------------------------------------------------------------------- */

static void test_resample_straight_nonuniform(void **state)
{
    (void)state;
    float in[3 * 6], out[3 * 11];
    for (int i = 0; i < 6; i++) { /* points at t^2 along a line: uneven spacing */
        float t = (float)(i * i) / 25.0f;
        in[3 * i + 0] = 1.0f + 2.0f * t;
        in[3 * i + 1] = -1.0f * t;
        in[3 * i + 2] = 0.5f + 2.0f * t;
    }
    core_err e;
    assert_int_equal(groom_resample_polyline(in, 6, out, 11, &e), CORE_OK);
    assert_memory_equal(out, in, 3 * sizeof(float));
    assert_memory_equal(out + 30, in + 15, 3 * sizeof(float));
    for (int j = 0; j < 11; j++) {
        float t = (float)j / 10.0f;
        assert_float_equal(out[3 * j + 0], 1.0f + 2.0f * t, 1e-5f);
        assert_float_equal(out[3 * j + 1], -1.0f * t, 1e-5f);
        assert_float_equal(out[3 * j + 2], 0.5f + 2.0f * t, 1e-5f);
    }
}

static void test_resample_corner_and_duplicates(void **state)
{
    (void)state;
    /* an L: (0,0,0) -> (1,0,0) -> (1,1,0), with a repeated corner point */
    const float in[] = { 0, 0, 0, 1, 0, 0, 1, 0, 0, 1, 1, 0 };
    float out[3 * 5];
    core_err e;
    assert_int_equal(groom_resample_polyline(in, 4, out, 5, &e), CORE_OK);
    const float want[] = { 0, 0, 0, 0.5f, 0, 0, 1, 0, 0, 1, 0.5f, 0, 1, 1, 0 };
    for (int i = 0; i < 15; i++) assert_float_equal(out[i], want[i], 1e-6f);
    /* downsampling to two points keeps exactly the end points */
    assert_int_equal(groom_resample_polyline(in, 4, out, 2, &e), CORE_OK);
    assert_memory_equal(out, in, 3 * sizeof(float));
    assert_memory_equal(out + 3, in + 9, 3 * sizeof(float));
}

static void test_resample_errors(void **state)
{
    (void)state;
    const float in[] = { 1, 2, 3, 1, 2, 3, 1, 2, 3 };
    float out[9];
    core_err e;
    assert_int_equal(groom_resample_polyline(in, 1, out, 3, &e), CORE_EINVAL);
    assert_int_equal(groom_resample_polyline(in, 3, out, 1, &e), CORE_EINVAL);
    assert_int_equal(groom_resample_polyline(in, 3, out, 3, &e), CORE_EINVAL);
    assert_non_null(strstr(e.msg, "zero"));
}

/* ---- .tfx ---------------------------------------------------------------------------- */

static void test_tfx_valid(void **state)
{
    (void)state;
    size_t size;
    unsigned char *b = make_tfx(3, 5, &size);
    core_err e;
    core_groom g;
    assert_int_equal(groom_load_tfx(b, size, 0, &g, &e), CORE_OK);
    assert_int_equal(g.nstrands, 3);
    assert_int_equal(g.nverts, 5);
    assert_int_equal(g.ncolliders, 0);
    for (uint32_t s = 0; s < 3; s++)
        for (uint32_t v = 0; v < 5; v++) {
            core_vec3 p = vtx(&g, s, v), want = line_point(s, 0.01f * (float)v);
            assert_float_equal(p.x, want.x, 1e-6f);
            assert_float_equal(p.y, want.y, 1e-6f);
            assert_float_equal(p.z, want.z, 1e-6f);
        }
    core_groom_free(&g);
    assert_int_equal(groom_load_tfx(b, size, 9, &g, &e), CORE_OK); /* upsample to 9: spacing 0.005 */
    assert_int_equal(g.nverts, 9);
    for (uint32_t s = 0; s < 3; s++)
        for (uint32_t v = 0; v < 9; v++) {
            core_vec3 p = vtx(&g, s, v), want = line_point(s, 0.005f * (float)v);
            assert_true(core_v3_len(core_v3_sub(p, want)) < 1e-6f);
        }
    core_groom_free(&g);
    assert_int_equal(groom_load_tfx(b, size, 1, &g, &e), CORE_EINVAL);
    assert_int_equal(groom_load_tfx(b, size, GROOM_MAX_VERTS + 1, &g, &e), CORE_EINVAL);
    free(b);
}

static void test_tfx_broken(void **state)
{
    (void)state;
    enum { NS = 3, NV = 5 };
    const size_t pos = 160, uv = pos + NS * NV * 16;
    static const struct {
        const char *what;
        size_t off;      /* where to write value (SIZE_MAX = truncate to value bytes) */
        uint32_t value;
        int is_float;
        float f;
        const char *word;
    } cases[] = {
        { "short header", SIZE_MAX, 100, 0, 0, "truncated" },
        { "positions cut", SIZE_MAX, 160 + 100, 0, 0, "truncated" },
        { "uvs cut", SIZE_MAX, 160 + NS * NV * 16 + 4, 0, 0, "strand UVs" },
        { "nan version", 0, 0, 1, NAN, "version" },
        { "zero version", 0, 0, 1, 0.0f, "version" },
        { "no strands", 4, 0, 0, 0, "numHairStrands" },
        { "too many strands", 4, (1u << 22) + 1, 0, 0, "numHairStrands" },
        { "strands disagree", 4, NS + 1, 0, 0, "truncated" },
        { "one vertex", 8, 1, 0, 0, "numVerticesPerStrand" },
        { "huge vertices", 8, 0xffffffffu, 0, 0, "numVerticesPerStrand" },
        { "no positions", 12, 0, 0, 0, "no vertex positions" },
        { "positions in header", 12, 16, 0, 0, "header" },
        { "positions out of range", 12, 0xfffffff0u, 0, 0, "out of range" },
        { "uv in header", 16, 40, 0, 0, "header" },
        { "uv out of range", 16, 0x7fffffffu, 0, 0, "out of range" },
        { "uv inside positions", 16, 160 + 32, 0, 0, "overlaps the positions" },
        { "color out of range", 28, (uint32_t)(160 + NS * NV * 16 + NS * 8), 0, 0, "out of range" },
        { "nan position", 160 + (NV + 2) * 16 + 4, 0, 1, NAN, "strand 1 vertex 2" },
        { "inf position", 160 + 8, 0, 1, INFINITY, "non-finite" },
    };
    (void)uv;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        size_t size;
        unsigned char *b = make_tfx(NS, NV, &size);
        if (cases[i].off == SIZE_MAX) size = cases[i].value;
        else if (cases[i].is_float) put_f32(b, cases[i].off, cases[i].f);
        else put_u32(b, cases[i].off, cases[i].value);
        core_err e = { { 0 } };
        core_groom g;
        core_status st = groom_load_tfx(b, size, 0, &g, &e);
        if (st != CORE_EFORMAT || !strstr(e.msg, cases[i].word))
            fail_msg("case '%s': status %d, message '%s' (want '%s')", cases[i].what, st, e.msg, cases[i].word);
        assert_null(g.pos);
        free(b);
    }
    /* counts that are each in range but together exceed the vertex limit */
    size_t size;
    unsigned char *b = make_tfx(NS, NV, &size);
    core_err e;
    core_groom g;
    put_u32(b, 4, GROOM_MAX_STRANDS);
    put_u32(b, 8, GROOM_MAX_VERTS);
    assert_int_equal(groom_load_tfx(b, size, 0, &g, &e), CORE_EFORMAT);
    assert_non_null(strstr(e.msg, "limit"));
    free(b);
    /* a strand whose points all coincide */
    b = make_tfx(NS, NV, &size);
    for (uint32_t v = 1; v < NV; v++) memcpy(b + pos + (2 * NV + v) * 16, b + pos + 2 * NV * 16, 16);
    assert_int_equal(groom_load_tfx(b, size, 0, &g, &e), CORE_EFORMAT);
    assert_non_null(strstr(e.msg, "strand 2"));
    assert_non_null(strstr(e.msg, "zero length"));
    assert_int_equal(groom_load_tfx(NULL, 0, 0, &g, &e), CORE_EFORMAT);
    free(b);
}

/* ---- .hair --------------------------------------------------------------------------- */

static void test_hair_valid(void **state)
{
    (void)state;
    static const uint32_t counts[] = { 2, 4, 7 };
    size_t size;
    unsigned char *b = make_hair(3, counts, HAIR_ALL, &size);
    core_err e;
    core_groom g;
    assert_int_equal(groom_load_hair(b, size, 0, &g, &e), CORE_OK); /* varying counts: default target */
    assert_int_equal(g.nstrands, 3);
    assert_int_equal(g.nverts, GROOM_DEFAULT_VERTS);
    assert_int_equal(g.ncolliders, 0);
    core_groom_free(&g);
    assert_int_equal(groom_load_hair(b, size, 7, &g, &e), CORE_OK);
    for (uint32_t s = 0; s < 3; s++) {
        float len = 0.01f * (float)(counts[s] - 1);
        for (uint32_t v = 0; v < 7; v++) {
            core_vec3 p = vtx(&g, s, v), want = line_point(s, len * (float)v / 6.0f);
            assert_true(core_v3_len(core_v3_sub(p, want)) < 1e-6f);
        }
    }
    core_groom_free(&g);
    free(b);

    /* no segments array: every strand has d_segments + 1 points, kept as is */
    static const uint32_t four[] = { 4 };
    b = make_hair(5, four, 2 | 16, &size);
    assert_int_equal(groom_load_hair(b, size, 0, &g, &e), CORE_OK);
    assert_int_equal(g.nstrands, 5);
    assert_int_equal(g.nverts, 4);
    for (uint32_t s = 0; s < 5; s++)
        for (uint32_t v = 0; v < 4; v++) {
            core_vec3 p = vtx(&g, s, v), want = line_point(s, 0.01f * (float)v);
            assert_true(core_v3_len(core_v3_sub(p, want)) < 1e-6f);
        }
    core_groom_free(&g);
    free(b);
}

static void test_hair_broken(void **state)
{
    (void)state;
    static const uint32_t counts[] = { 2, 4, 7 };
    const size_t pts = 128 + 6;
    static const struct {
        const char *what;
        size_t off;      /* SIZE_MAX: set the size to value; SIZE_MAX - 1: add value bytes */
        uint32_t value;
        int width;       /* 4 = u32, 2 = u16, 1 = byte, 0 = float f */
        float f;
        const char *word;
    } cases[] = {
        { "short header", SIZE_MAX, 127, 4, 0, "truncated" },
        { "cut arrays", SIZE_MAX, 128 + 6 + 50, 4, 0, "truncated" },
        { "trailing bytes", SIZE_MAX - 1, 8, 4, 0, "trailing" },
        { "wrong magic", 0, 'X', 1, 0, "magic" },
        { "no hairs", 4, 0, 4, 0, "hair count" },
        { "too many hairs", 4, 0xffffffffu, 4, 0, "hair count" },
        { "points overflow", 8, 0xffffffffu, 4, 0, "point count" },
        { "points disagree with size", 8, 14, 4, 0, "truncated" },
        { "unknown flags", 12, HAIR_ALL | 64, 4, 0, "unknown array flags" },
        { "no points", 12, 1 | 4, 4, 0, "no points" },
        { "colors missing", 12, HAIR_ALL & ~16u, 4, 0, "trailing" },
        { "segments disagree", 128 + 2, 4, 2, 0, "segment counts" },
        { "one-point strand", 128 + 4, 0, 2, 0, "< 2 points" },
        { "nan point", 128 + 6 + 12 * 3 + 4, 0, 0, NAN, "strand 1 vertex 1" },
        { "inf point", 128 + 6, 0, 0, -INFINITY, "non-finite" },
    };
    (void)pts;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        size_t size;
        unsigned char *b = make_hair(3, counts, HAIR_ALL, &size);
        unsigned char *big = NULL;
        if (cases[i].off == SIZE_MAX) size = cases[i].value;
        else if (cases[i].off == SIZE_MAX - 1) {
            big = calloc(1, size + cases[i].value);
            memcpy(big, b, size);
            size += cases[i].value;
        } else if (cases[i].width == 4) put_u32(b, cases[i].off, cases[i].value);
        else if (cases[i].width == 2) put_u16(b, cases[i].off, (uint16_t)cases[i].value);
        else if (cases[i].width == 1) b[cases[i].off] = (unsigned char)cases[i].value;
        else put_f32(b, cases[i].off, cases[i].f);
        core_err e = { { 0 } };
        core_groom g;
        core_status st = groom_load_hair(big ? big : b, size, 0, &g, &e);
        if (st != CORE_EFORMAT || !strstr(e.msg, cases[i].word))
            fail_msg("case '%s': status %d, message '%s' (want '%s')", cases[i].what, st, e.msg, cases[i].word);
        assert_null(g.pos);
        free(big);
        free(b);
    }
    /* default segment count 0 without a segments array; zero-length strand */
    static const uint32_t three[] = { 3 };
    size_t size;
    unsigned char *b = make_hair(2, three, 2, &size);
    put_u32(b, 16, 0);
    core_err e;
    core_groom g;
    assert_int_equal(groom_load_hair(b, size, 0, &g, &e), CORE_EFORMAT);
    assert_non_null(strstr(e.msg, "default segment count"));
    free(b);
    b = make_hair(2, three, 2, &size);
    memcpy(b + 128 + 36 + 12, b + 128 + 36, 12);
    memcpy(b + 128 + 36 + 24, b + 128 + 36, 12);
    assert_int_equal(groom_load_hair(b, size, 0, &g, &e), CORE_EFORMAT);
    assert_non_null(strstr(e.msg, "strand 1"));
    assert_non_null(strstr(e.msg, "zero length"));
    free(b);
}

/* ---- robustness: every prefix, random byte flips -------------------------------------- */

static void check_any(const unsigned char *b, size_t size, int tfx)
{
    core_err e;
    core_groom g;
    core_status st = tfx ? groom_load_tfx(b, size, 8, &g, &e) : groom_load_hair(b, size, 8, &g, &e);
    assert_true(st == CORE_OK || st == CORE_EFORMAT);
    if (st == CORE_OK) {
        assert_int_equal(g.nverts, 8);
        assert_finite(&g);
        core_groom_free(&g);
    } else {
        assert_true(strlen(e.msg) > 0);
        assert_null(g.pos);
    }
}

static void test_truncation_and_flips(void **state)
{
    (void)state;
    static const uint32_t counts[] = { 2, 5, 3, 9 };
    for (int tfx = 0; tfx < 2; tfx++) {
        size_t size;
        unsigned char *b = tfx ? make_tfx(4, 6, &size) : make_hair(4, counts, HAIR_ALL, &size);
        for (size_t n = 0; n < size; n++) { /* every strict prefix is refused */
            unsigned char *cut = malloc(n ? n : 1);
            memcpy(cut, b, n);
            core_err e;
            core_groom g;
            core_status st = tfx ? groom_load_tfx(cut, n, 0, &g, &e) : groom_load_hair(cut, n, 0, &g, &e);
            if (st != CORE_EFORMAT) fail_msg("%s prefix of %zu bytes: status %d", tfx ? "tfx" : "hair", n, st);
            free(cut);
        }
        uint64_t rs = 0x600d5eed + (uint64_t)tfx;
        unsigned char *m = malloc(size);
        for (int iter = 0; iter < 3000; iter++) {
            memcpy(m, b, size);
            int flips = 1 + (int)(rng_state(&rs) % 4);
            for (int k = 0; k < flips; k++) {
                /* bias toward the header, where flips change counts and offsets */
                size_t at = (rng_state(&rs) & 1) ? rng_state(&rs) % 48 : rng_state(&rs) % size;
                m[at] ^= (unsigned char)(1u << (rng_state(&rs) % 8));
            }
            size_t n = (rng_state(&rs) % 8 == 0) ? rng_state(&rs) % size : size;
            check_any(m, n, tfx);
        }
        free(m);
        free(b);
    }
}

/* ---- files and fitted colliders ------------------------------------------------------ */

static void write_file(const char *path, const unsigned char *b, size_t size)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(b, 1, size, f), size);
    assert_int_equal(fclose(f), 0);
}

/* One fitted head ellipsoid, finite, semi-axes in [5 mm, 0.2 m], every finite root outside it
 * by the 1 mm margin (outside the ellipsoid with 1 mm longer semi-axes). */
static void assert_roots_outside_fit(const core_groom *g)
{
    assert_int_equal(g->ncolliders, 1);
    const core_collider *c = &g->colliders[0];
    assert_int_equal(c->kind, CORE_COLLIDER_ELLIPSOID);
    const float r[3] = { c->radii.x, c->radii.y, c->radii.z }, a[3] = { c->a.x, c->a.y, c->a.z };
    for (int k = 0; k < 3; k++) {
        assert_true(isfinite(a[k]));
        if (!(r[k] >= 0.005f && r[k] <= 0.2f)) fail_msg("semi-axis %d = %g", k, (double)r[k]);
    }
    assert_true(c->rot.x == 0.0f && c->rot.y == 0.0f && c->rot.z == 0.0f && c->rot.w == 1.0f);
    core_collider grown = *c;
    grown.radii = core_v3(c->radii.x + 0.001f, c->radii.y + 0.001f, c->radii.z + 0.001f);
    for (uint32_t s = 0; s < g->nstrands; s++) {
        core_vec3 p = vtx(g, s, 0);
        if (isfinite(p.x) && isfinite(p.y) && isfinite(p.z)) assert_false(inside(&grown, p));
    }
}

static void test_load_file(void **state)
{
    (void)state;
    char dir[] = "/tmp/test_groom_XXXXXX", path[64];
    assert_non_null(mkdtemp(dir));
    size_t size;
    unsigned char *b = make_tfx(6, 5, &size);
    snprintf(path, sizeof path, "%s/a.TFX", dir);
    write_file(path, b, size);
    core_err e;
    core_groom g;
    assert_int_equal(groom_load_file(path, 10, &g, &e), CORE_OK);
    assert_int_equal(g.nstrands, 6);
    assert_int_equal(g.nverts, 10);
    assert_roots_outside_fit(&g);
    core_groom_free(&g);
    free(b);
    assert_int_equal(unlink(path), 0);

    static const uint32_t counts[] = { 3, 3 };
    b = make_hair(2, counts, 3, &size);
    snprintf(path, sizeof path, "%s/b.hair", dir);
    write_file(path, b, size);
    assert_int_equal(groom_load_file(path, 0, &g, &e), CORE_OK);
    assert_int_equal(g.nverts, 3);
    core_groom_free(&g);
    put_u16(b, 128, 3); /* now the segment counts disagree: the message names the file */
    write_file(path, b, size);
    assert_int_equal(groom_load_file(path, 0, &g, &e), CORE_EFORMAT);
    assert_non_null(strstr(e.msg, "b.hair"));
    assert_non_null(strstr(e.msg, "segment counts"));
    free(b);
    assert_int_equal(unlink(path), 0);

    snprintf(path, sizeof path, "%s/missing.tfx", dir);
    assert_int_equal(groom_load_file(path, 0, &g, &e), CORE_EIO);
    assert_non_null(strstr(e.msg, "missing.tfx"));
    snprintf(path, sizeof path, "%s/groom.obj", dir);
    assert_int_equal(groom_load_file(path, 0, &g, &e), CORE_EINVAL);
    assert_non_null(strstr(e.msg, "extension"));
    assert_int_equal(rmdir(dir), 0);
}

/* The fitting fixture's head: an ellipsoid not at the origin. */
static const core_vec3 fix_c = { 0.0f, 1.6f, 0.0f }, fix_r = { 0.08f, 0.10f, 0.095f };

static core_vec3 fix_project_out(core_vec3 p, core_vec3 c, core_vec3 r, float margin)
{
    core_vec3 l = core_v3_sub(p, c);
    float x = l.x / (r.x + margin), y = l.y / (r.y + margin), z = l.z / (r.z + margin), f = x * x + y * y + z * z;
    if (f >= 1.0f) return p;
    return core_v3_add(c, core_v3_scale(l, 1.0f / sqrtf(f)));
}

typedef enum fix_hair { FIX_HANGING, FIX_OUTWARD } fix_hair;

/* ns strands x nv vertices, length 0.4 m, roots on the ellipsoid (c, r) at unit directions
 * spread over the part with direction y >= ymin (golden-spiral order, deterministic).
 * FIX_HANGING: the first segment points down as far as the scalp allows (-y along the
 * surface, to the back at the crown), then every segment goes -y, draped 1 mm outside the
 * ellipsoid. FIX_OUTWARD: the first three segments go along the surface normal, then -y. */
static void fix_groom(core_groom *g, uint32_t ns, uint32_t nv, core_vec3 c, core_vec3 r, float ymin, fix_hair hair)
{
    core_err e;
    assert_int_equal(core_groom_alloc(g, ns, nv, &e), CORE_OK);
    float seg = 0.4f / (float)(nv - 1);
    for (uint32_t s = 0; s < ns; s++) {
        float u = ((float)s + 0.5f) / (float)ns, y = ymin + (1.0f - ymin) * u, ring = sqrtf(fmaxf(0.0f, 1.0f - y * y));
        float phi = 2.399963f * (float)s;
        core_vec3 d = core_v3(ring * cosf(phi), y, ring * sinf(phi));
        core_vec3 root = core_v3_add(c, core_v3(d.x * r.x, d.y * r.y, d.z * r.z));
        core_vec3 n = core_v3_norm(core_v3(d.x / r.x, d.y / r.y, d.z / r.z));
        core_vec3 down = core_v3(0.0f, -1.0f, 0.0f), first;
        if (hair == FIX_HANGING) {
            first = core_v3_sub(down, core_v3_scale(n, core_v3_dot(down, n)));
            first = core_v3_len(first) > 1e-3f ? core_v3_norm(first) : core_v3(0.0f, 0.0f, -1.0f);
            first = core_v3_norm(core_v3_add(first, core_v3_scale(n, 0.02f))); /* just off the scalp */
        } else {
            first = n;
        }
        float *p = g->pos + (size_t)s * nv * 3;
        p[0] = root.x, p[1] = root.y, p[2] = root.z;
        core_vec3 prev = root;
        for (uint32_t v = 1; v < nv; v++) {
            core_vec3 dir = v == 1 || (hair == FIX_OUTWARD && v <= 3) ? first : down;
            core_vec3 q = core_v3_add(prev, core_v3_scale(dir, seg));
            if (v > 1) {
                q = fix_project_out(q, c, r, 0.001f);
                q = core_v3_add(prev, core_v3_scale(core_v3_norm(core_v3_sub(q, prev)), seg));
            }
            p[3 * v] = q.x, p[3 * v + 1] = q.y, p[3 * v + 2] = q.z;
            prev = q;
        }
    }
}

/* The fit is within tol_c (m) of centre c and rel_r of radii r; reports the figures. */
static void assert_fit_near(const core_groom *g, core_vec3 c, core_vec3 r, float tol_c, float rel_r, const char *what)
{
    assert_roots_outside_fit(g);
    const core_collider *h = &g->colliders[0];
    float dc = core_v3_len(core_v3_sub(h->a, c));
    float er[3] = { h->radii.x / r.x - 1.0f, h->radii.y / r.y - 1.0f, h->radii.z / r.z - 1.0f };
    printf("%s: centre (%.4f %.4f %.4f) off by %.1f mm, radii (%.4f %.4f %.4f) off by %+.1f%% %+.1f%% %+.1f%%\n", what,
           (double)h->a.x, (double)h->a.y, (double)h->a.z, 1e3 * (double)dc, (double)h->radii.x, (double)h->radii.y,
           (double)h->radii.z, 100.0 * er[0], 100.0 * er[1], 100.0 * er[2]);
    assert_true(dc < tol_c);
    for (int k = 0; k < 3; k++) assert_true(fabsf(er[k]) < rel_r);
}

/* Hanging long hair: the old fit (first-segment direction) put its sphere above the head; the
 * roots alone give the head back. Then 2 s of the C solver leave < 1% of strands inside it. */
static void test_fit_hanging(void **state)
{
    (void)state;
    core_groom g;
    fix_groom(&g, 600, 16, fix_c, fix_r, 0.0f, FIX_HANGING);
    double mean_dy = 0.0; /* the fixture's hair does start downward */
    for (uint32_t s = 0; s < g.nstrands; s++) mean_dy += vtx(&g, s, 1).y - vtx(&g, s, 0).y;
    assert_true(mean_dy < 0.0);
    groom_fit_colliders(&g);
    assert_fit_near(&g, fix_c, fix_r, 0.015f, 0.15f, "hanging hair fit");

    sim_params p;
    sim_params_default(&p);
    sim_desc d = { .backend = SIM_BACKEND_CPU, .threads = 2 };
    sim sm;
    core_err e;
    if (sim_create(&sm, &d, &g, &p, &e) != CORE_OK) fail_msg("sim_create: %s", e.msg);
    int steps = (int)lround(2.0 / p.dt);
    for (int i = 0; i < steps; i++) {
        sim_set_motion(&sm, core_xform_identity());
        if (sim_step(&sm, &e) != CORE_OK) fail_msg("sim_step: %s", e.msg);
    }
    float *x = malloc(sizeof(float) * 3 * g.nstrands * g.nverts);
    assert_non_null(x);
    assert_int_equal(sim_read_positions(&sm, x, &e), CORE_OK);
    /* a strand is in when a vertex is deeper than 0.1 mm: the solver leaves colliding vertices
     * on the surface, where float rounding puts some a few nm inside */
    core_collider shrunk = g.colliders[0];
    shrunk.radii = core_v3(shrunk.radii.x - 1e-4f, shrunk.radii.y - 1e-4f, shrunk.radii.z - 1e-4f);
    uint32_t in = 0, touching = 0;
    for (uint32_t s = 0; s < g.nstrands; s++) {
        int any = 0, touch = 0;
        for (uint32_t v = 1; v < g.nverts; v++) {
            const float *q = x + ((size_t)s * g.nverts + v) * 3;
            any |= inside(&shrunk, core_v3(q[0], q[1], q[2]));
            touch |= inside(&g.colliders[0], core_v3(q[0], q[1], q[2]));
        }
        in += (uint32_t)any;
        touching += (uint32_t)touch;
    }
    double deepest = simcheck_deepest_penetration(&g, core_xform_identity(), x);
    printf("after %d steps: %u of %u strands (%.2f%%) have a vertex over 0.1 mm inside the fitted head "
           "(%u on or inside its surface), deepest %.3g of its radius\n",
           steps, in, g.nstrands, 100.0 * in / g.nstrands, touching, deepest);
    assert_true(in * 100u < g.nstrands);
    free(x);
    sim_destroy(&sm);
    core_groom_free(&g);
}

static void test_fit_outward(void **state)
{
    (void)state;
    core_groom g;
    fix_groom(&g, 600, 16, fix_c, fix_r, 0.0f, FIX_OUTWARD);
    groom_fit_colliders(&g);
    assert_fit_near(&g, fix_c, fix_r, 0.015f, 0.15f, "outward hair fit");
    core_groom_free(&g);
}

/* Roots on a sphere patch only at the top (directions within ~50 degrees of +y). */
static void test_fit_top_patch(void **state)
{
    (void)state;
    core_groom g;
    const core_vec3 c = { 0.02f, 1.5f, -0.01f }, r = { 0.09f, 0.09f, 0.09f };
    fix_groom(&g, 300, 8, c, r, 0.64f, FIX_HANGING);
    groom_fit_colliders(&g);
    assert_fit_near(&g, c, r, 0.015f, 0.15f, "top patch fit");
    core_groom_free(&g);
}

/* Degenerate root sets: a sane collider (finite, plausible, every root outside) or none. */
static void check_degenerate(const float *roots, uint32_t n, const char *what)
{
    core_groom g;
    core_err e;
    assert_int_equal(core_groom_alloc(&g, n, 2, &e), CORE_OK);
    for (uint32_t s = 0; s < n; s++) {
        float *p = g.pos + (size_t)s * 6;
        memcpy(p, roots + 3 * s, sizeof(float) * 3);
        p[3] = roots[3 * s], p[4] = roots[3 * s + 1] - 0.01f, p[5] = roots[3 * s + 2];
    }
    groom_fit_colliders(&g);
    printf("%s: %u collider(s)\n", what, g.ncolliders);
    if (g.ncolliders) {
        assert_roots_outside_fit(&g);
        const core_collider *c = &g.colliders[0];
        printf("  centre (%.4f %.4f %.4f) radii (%.4f %.4f %.4f)\n", (double)c->a.x, (double)c->a.y, (double)c->a.z,
               (double)c->radii.x, (double)c->radii.y, (double)c->radii.z);
    }
    core_groom_free(&g);
}

static void test_fit_degenerate(void **state)
{
    (void)state;
    float one[3] = { 0.1f, 1.7f, 0.0f };
    check_degenerate(one, 1, "one strand");
    float same[12] = { 0.1f, 1.7f, 0, 0.1f, 1.7f, 0, 0.1f, 1.7f, 0, 0.1f, 1.7f, 0 };
    check_degenerate(same, 4, "four identical roots");
    float line[30];
    for (int i = 0; i < 10; i++) line[3 * i] = 0.02f * (float)i, line[3 * i + 1] = 1.7f + 0.01f * (float)i, line[3 * i + 2] = 0.0f;
    check_degenerate(line, 10, "collinear roots");
    float plane[75];
    for (int i = 0; i < 25; i++) plane[3 * i] = 0.03f * (float)(i % 5), plane[3 * i + 1] = 1.7f, plane[3 * i + 2] = 0.03f * (float)(i / 5);
    check_degenerate(plane, 25, "coplanar roots");
    float wide[75];
    for (int i = 0; i < 25; i++) wide[3 * i] = 3.0f * (float)(i % 5), wide[3 * i + 1] = 1.7f, wide[3 * i + 2] = 2.0f * (float)(i / 5);
    check_degenerate(wide, 25, "coplanar roots metres apart");
    float mixed[15] = { 0.0f, 1.7f, 0.0f, NAN, 1.0f, 0.0f, 0.05f, 1.68f, 0.0f, INFINITY, 0.0f, 0.0f, 0.0f, 1.68f, 0.05f };
    check_degenerate(mixed, 5, "non-finite roots among finite ones");
    float bad[6] = { NAN, NAN, NAN, INFINITY, -INFINITY, 0.0f };
    core_groom g;
    core_err e;
    assert_int_equal(core_groom_alloc(&g, 2, 2, &e), CORE_OK);
    memcpy(g.pos, bad, sizeof bad);
    memcpy(g.pos + 6, bad, sizeof bad);
    groom_fit_colliders(&g);
    assert_int_equal(g.ncolliders, 0); /* no finite root: no collider */
    core_groom_free(&g);
}

static void test_fit_colliders(void **state)
{
    (void)state;
    core_err e;
    core_groom g;
    groom_desc desc = { .nstrands = 800, .nverts = 8, .seed = 9 };
    assert_int_equal(groom_procedural(&desc, &g, &e), CORE_OK);
    groom_fit_colliders(&g);
    /* the procedural roots lie 1 mm outside the default head, which the fit finds again */
    assert_fit_near(&g, core_v3(0.0f, 0.0f, 0.0f), core_v3(GROOM_HEAD_RX, GROOM_HEAD_RY, GROOM_HEAD_RZ), 0.015f, 0.15f,
                    "procedural groom fit");
    core_groom_free(&g);
}

static void test_ratboy(void **state)
{
    (void)state;
    const char *assets = getenv("STRANDCAST_ASSETS");
    char path[4096];
    if (!assets) skip();
    snprintf(path, sizeof path, "%s/ratboy/Ratboy_mohawk.tfx", assets);
    if (access(path, R_OK) != 0) skip();
    core_err e;
    core_groom g;
    if (groom_load_file(path, 32, &g, &e) != CORE_OK) fail_msg("%s", e.msg);
    assert_int_equal(g.nstrands, 2228);
    assert_int_equal(g.nverts, 32);
    assert_finite(&g);
    float lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (size_t i = 0; i < (size_t)g.nstrands * g.nverts; i++)
        for (int c = 0; c < 3; c++) {
            lo[c] = fminf(lo[c], g.pos[3 * i + c]);
            hi[c] = fmaxf(hi[c], g.pos[3 * i + c]);
        }
    const float want_lo[3] = { -0.096f, 0.214f, -0.336f }, want_hi[3] = { 0.118f, 1.110f, 0.271f };
    for (int c = 0; c < 3; c++) {
        assert_float_equal(lo[c], want_lo[c], 0.003f);
        assert_float_equal(hi[c], want_hi[c], 0.003f);
    }
    assert_roots_outside_fit(&g);
    /* the head sits under the mohawk: centre below the roots' centroid, between their x and z */
    const core_collider *h = &g.colliders[0];
    core_vec3 m = core_v3(0, 0, 0), rlo = vtx(&g, 0, 0), rhi = rlo;
    for (uint32_t s = 0; s < g.nstrands; s++) {
        core_vec3 r = vtx(&g, s, 0);
        m = core_v3_add(m, core_v3_scale(r, 1.0f / (float)g.nstrands));
        rlo = core_v3(fminf(rlo.x, r.x), fminf(rlo.y, r.y), fminf(rlo.z, r.z));
        rhi = core_v3(fmaxf(rhi.x, r.x), fmaxf(rhi.y, r.y), fmaxf(rhi.z, r.z));
    }
    printf("ratboy roots (%.3f..%.3f, %.3f..%.3f, %.3f..%.3f), fitted head centre (%.4f %.4f %.4f) radii (%.4f %.4f %.4f)\n",
           (double)rlo.x, (double)rhi.x, (double)rlo.y, (double)rhi.y, (double)rlo.z, (double)rhi.z, (double)h->a.x,
           (double)h->a.y, (double)h->a.z, (double)h->radii.x, (double)h->radii.y, (double)h->radii.z);
    assert_true(h->a.y < m.y);
    assert_true(h->a.x >= rlo.x && h->a.x <= rhi.x && h->a.z >= rlo.z && h->a.z <= rhi.z);
    core_groom_free(&g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_procedural_counts_determinism),
        cmocka_unit_test(test_procedural_roots_on_scalp),
        cmocka_unit_test(test_procedural_outside_colliders),
        cmocka_unit_test(test_procedural_segment_lengths),
        cmocka_unit_test(test_procedural_styles_differ),
        cmocka_unit_test(test_procedural_bad_desc),
        cmocka_unit_test(test_style_names),
        cmocka_unit_test(test_resample_straight_nonuniform),
        cmocka_unit_test(test_resample_corner_and_duplicates),
        cmocka_unit_test(test_resample_errors),
        cmocka_unit_test(test_tfx_valid),
        cmocka_unit_test(test_tfx_broken),
        cmocka_unit_test(test_hair_valid),
        cmocka_unit_test(test_hair_broken),
        cmocka_unit_test(test_truncation_and_flips),
        cmocka_unit_test(test_load_file),
        cmocka_unit_test(test_fit_colliders),
        cmocka_unit_test(test_fit_hanging),
        cmocka_unit_test(test_fit_outward),
        cmocka_unit_test(test_fit_top_patch),
        cmocka_unit_test(test_fit_degenerate),
        cmocka_unit_test(test_ratboy),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
