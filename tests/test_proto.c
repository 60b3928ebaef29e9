/* Tests for server/proto: every client message, every rejection path, hostile inputs, builders. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/utf8.h"
#include "proto/proto.h"

typedef struct test_params {
    float gravity;
    int32_t substeps;
    bool sph;
    float stiffness;
} test_params;

static const core_param_info table[] = {
    { "gravity", CORE_PARAM_FLOAT, offsetof(test_params, gravity), 0.0, 50.0, 9.81, "m/s^2", "Gravity.", CORE_PARAM_LINEAR, NULL, NULL },
    { "substeps", CORE_PARAM_INT, offsetof(test_params, substeps), 1, 16, 1, "", "Substeps.", CORE_PARAM_LINEAR, NULL, NULL },
    { "sph", CORE_PARAM_BOOL, offsetof(test_params, sph), 0, 1, 1, "", "SPH on.", CORE_PARAM_LINEAR, NULL, NULL },
    { "stiffness", CORE_PARAM_FLOAT, offsetof(test_params, stiffness), 0.0, 0.3, 0.2, "", "Stiffness \"quoted\".", CORE_PARAM_LOG, NULL, NULL },
};
static const char *const presets[] = { "none", "nod", "shake", "circle" };
static const char *const styles[] = { "straight", "wavy", "curly" };
static const proto_parser parser = { table, 4, presets, 4, styles, 3 };

/* A table with an enum (the solver) and parameters of one solver each. */
typedef struct solver_params {
    int32_t solver;
    int32_t iterations;
    float correction;
} solver_params;
static const char *const solver_choices[] = { "dftl", "hairmesh", "pbd" };
static const char *const only_pbd[] = { "pbd", NULL };
static const char *const only_dftl[] = { "dftl", NULL };
static const core_param_info stable[] = {
    { "solver", CORE_PARAM_ENUM, offsetof(solver_params, solver), 0, 2, 0, "", "Solver.", CORE_PARAM_LINEAR,
      solver_choices, NULL },
    { "iterations", CORE_PARAM_INT, offsetof(solver_params, iterations), 1, 32, 4, "", "Iterations.", CORE_PARAM_LINEAR,
      NULL, only_pbd },
    { "correction", CORE_PARAM_FLOAT, offsetof(solver_params, correction), 0, 1, 0.9, "", "Correction.",
      CORE_PARAM_LINEAR, NULL, only_dftl },
};
static const proto_parser sparser = { stable, 3, presets, 4, styles, 3 };

static proto_msg msg;
static proto_error err;

static core_status parse(const char *s) { return proto_parse(&parser, s, strlen(s), &msg, &err); }

static void expect_ok(const char *s, proto_type t)
{
    core_status st = parse(s);
    if (st != CORE_OK) fail_msg("rejected %s: %s %s %s", s, proto_code_name(err.code), err.field, err.message);
    assert_int_equal(msg.type, t);
}

static void expect_err(const char *s, proto_code code, const char *field)
{
    core_status st = parse(s);
    if (st == CORE_OK) fail_msg("accepted %s", s);
    if (err.code != code || strcmp(err.field, field) != 0)
        fail_msg("%s: got %s field '%s' (%s), want %s field '%s'", s, proto_code_name(err.code), err.field, err.message,
                 proto_code_name(code), field);
    assert_true(strlen(err.message) > 0);
}

/* Parses a builder's output (and frees it). */
static cJSON *json(char *text)
{
    assert_non_null(text);
    cJSON *j = cJSON_Parse(text);
    assert_non_null(j);
    proto_free(text);
    return j;
}

static const char *str_of(const cJSON *o, const char *k)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, k);
    assert_true(cJSON_IsString(v));
    return v->valuestring;
}

static double num_of(const cJSON *o, const char *k)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, k);
    assert_true(cJSON_IsNumber(v));
    return v->valuedouble;
}

static void test_simple_messages(void **state)
{
    (void)state;
    expect_ok("{\"type\":\"get_params\"}", PROTO_GET_PARAMS);
    assert_int_equal(msg.id.kind, PROTO_ID_NONE);
    expect_ok("{\"type\":\"reset\",\"id\":7}", PROTO_RESET);
    assert_int_equal(msg.id.kind, PROTO_ID_NUMBER);
    assert_true(msg.id.num == 7.0);
    expect_ok(" {\"id\":\"abc\",\"type\":\"pause\"} \n", PROTO_PAUSE);
    assert_int_equal(msg.id.kind, PROTO_ID_STRING);
    assert_string_equal(msg.id.str, "abc");
    expect_ok("{\"type\":\"resume\"}", PROTO_RESUME);
    expect_ok("{\"type\":\"keyframe\"}", PROTO_KEYFRAME);
    expect_ok("{\"type\":\"step\"}", PROTO_STEP);
    assert_int_equal(msg.u.step.count, 1);
    expect_ok("{\"type\":\"step\",\"count\":25}", PROTO_STEP);
    assert_int_equal(msg.u.step.count, 25);
}

static void test_set_params(void **state)
{
    (void)state;
    expect_ok("{\"type\":\"set_params\",\"id\":2,\"values\":{\"gravity\":0,\"sph\":false,\"substeps\":4}}", PROTO_SET_PARAMS);
    assert_int_equal(msg.u.set_params.count, 3);
    assert_int_equal(msg.u.set_params.v[0].index, 0);
    assert_true(msg.u.set_params.v[0].value == 0.0);
    assert_int_equal(msg.u.set_params.v[1].index, 2);
    assert_true(msg.u.set_params.v[1].value == 0.0);
    assert_int_equal(msg.u.set_params.v[2].index, 1);
    assert_true(msg.u.set_params.v[2].value == 4.0);
    expect_ok("{\"type\":\"set_params\",\"values\":{\"sph\":true,\"stiffness\":0.3,\"gravity\":50}}", PROTO_SET_PARAMS);
    assert_true(msg.u.set_params.v[0].value == 1.0);

    expect_err("{\"type\":\"set_params\"}", PROTO_ERR_BAD_FIELD, "values");
    expect_err("{\"type\":\"set_params\",\"values\":[1]}", PROTO_ERR_BAD_FIELD, "values");
    expect_err("{\"type\":\"set_params\",\"values\":{}}", PROTO_ERR_BAD_FIELD, "values");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravty\":1}}", PROTO_ERR_UNKNOWN_PARAM, "values.gravty");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":\"1\"}}", PROTO_ERR_BAD_FIELD, "values.gravity");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":null}}", PROTO_ERR_BAD_FIELD, "values.gravity");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":true}}", PROTO_ERR_BAD_FIELD, "values.gravity");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":-1}}", PROTO_ERR_OUT_OF_RANGE, "values.gravity");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":50.0001}}", PROTO_ERR_OUT_OF_RANGE, "values.gravity");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":1e999}}", PROTO_ERR_NOT_FINITE, "values.gravity");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":-1e999}}", PROTO_ERR_NOT_FINITE, "values.gravity");
    expect_err("{\"type\":\"set_params\",\"values\":{\"substeps\":2.5}}", PROTO_ERR_BAD_FIELD, "values.substeps");
    expect_err("{\"type\":\"set_params\",\"values\":{\"substeps\":0}}", PROTO_ERR_OUT_OF_RANGE, "values.substeps");
    expect_err("{\"type\":\"set_params\",\"values\":{\"substeps\":1e300}}", PROTO_ERR_OUT_OF_RANGE, "values.substeps");
    expect_err("{\"type\":\"set_params\",\"values\":{\"sph\":1}}", PROTO_ERR_BAD_FIELD, "values.sph");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":1,\"gravity\":2}}", PROTO_ERR_BAD_FIELD, "values.gravity");
    /* atomic: one bad value rejects the whole message */
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":1,\"stiffness\":0.5}}", PROTO_ERR_OUT_OF_RANGE,
               "values.stiffness");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":1,\"sph\":true,\"substeps\":2,\"stiffness\":0,\"x\":1}}",
               PROTO_ERR_TOO_LARGE, "values");
}

static void make_groom(core_groom *g);

/* An enum parameter: set by the name of a choice (its index in the message), anything else
 * refused with the choices listed; the schema carries the choices, a string default and the
 * solvers a parameter applies to; values go out as names. */
static void test_enum_params(void **state)
{
    (void)state;
    const char *ok = "{\"type\":\"set_params\",\"values\":{\"solver\":\"pbd\",\"iterations\":8}}";
    assert_int_equal(proto_parse(&sparser, ok, strlen(ok), &msg, &err), CORE_OK);
    assert_int_equal(msg.u.set_params.count, 2);
    assert_int_equal(msg.u.set_params.v[0].index, 0);
    assert_true(msg.u.set_params.v[0].value == 2.0);
    static const struct { const char *text, *why; proto_code code; } bad[] = {
        { "{\"type\":\"set_params\",\"values\":{\"solver\":\"verlet\"}}", "one of: dftl, hairmesh, pbd", PROTO_ERR_OUT_OF_RANGE },
        { "{\"type\":\"set_params\",\"values\":{\"solver\":2}}", "must be a string", PROTO_ERR_BAD_FIELD },
        { "{\"type\":\"set_params\",\"values\":{\"solver\":\"\"}}", "one of", PROTO_ERR_OUT_OF_RANGE },
        { "{\"type\":\"set_params\",\"values\":{\"solver\":\"PBD\"}}", "one of", PROTO_ERR_OUT_OF_RANGE },
        { "{\"type\":\"set_params\",\"values\":{\"solver\":null}}", "must be a string", PROTO_ERR_BAD_FIELD },
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        assert_int_equal(proto_parse(&sparser, bad[i].text, strlen(bad[i].text), &msg, &err), CORE_EINVAL);
        assert_int_equal(err.code, bad[i].code);
        assert_string_equal(err.field, "values.solver");
        if (!strstr(err.message, bad[i].why)) fail_msg("'%s': message '%s' lacks '%s'", bad[i].text, err.message, bad[i].why);
    }
    solver_params v = { 2, 8, 0.5f };
    cJSON *j = json(proto_build_params(NULL, stable, 3, &v, NULL, -1));
    const cJSON *values = cJSON_GetObjectItemCaseSensitive(j, "values");
    assert_string_equal(str_of(values, "solver"), "pbd");
    cJSON_Delete(j);
    core_groom g = { 0 };
    make_groom(&g);
    proto_data_ref dr = { "/groom.bin", "fedcba9876543210", 64 };
    proto_groom pg = { "procedural:straight", &g, 7, &dr, NULL, NULL };
    proto_groom_json gj;
    core_err cerr;
    assert_int_equal(proto_groom_json_build(&gj, &pg, &cerr), CORE_OK);
    proto_hello h = {
        .server = "strandcastd", .version = "0.1.0", .client = 5, .groom = &gj, .head = core_xform_identity(),
        .params = stable, .nparams = 3, .values = &v, .presets = presets, .npresets = 4,
        .animation = { "nod", 2.0 }, .styles = styles, .nstyles = 3,
        .stream = { "strand", 1, 3, 1e-4, 0, 60, 60, 30 }, .state = { true, 1.5, 90, { "nod", 2.0 } },
    };
    j = json(proto_build_hello(&h));
    const cJSON *schema = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(j, "params"), "schema");
    const cJSON *e = cJSON_GetArrayItem(schema, 0);
    assert_string_equal(str_of(e, "type"), "enum");
    assert_string_equal(str_of(e, "default"), "dftl");
    const cJSON *choices = cJSON_GetObjectItemCaseSensitive(e, "choices");
    assert_int_equal(cJSON_GetArraySize(choices), 3);
    assert_string_equal(cJSON_GetArrayItem(choices, 2)->valuestring, "pbd");
    assert_null(cJSON_GetObjectItemCaseSensitive(e, "solvers"));
    const cJSON *solvers = cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(schema, 1), "solvers");
    assert_int_equal(cJSON_GetArraySize(solvers), 1);
    assert_string_equal(cJSON_GetArrayItem(solvers, 0)->valuestring, "pbd");
    assert_null(cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(schema, 1), "choices"));
    cJSON_Delete(j);
    proto_groom_json_free(&gj);
    core_groom_free(&g);
}

static void test_motion(void **state)
{
    (void)state;
    expect_ok("{\"type\":\"motion\",\"t\":1234.5,\"position\":[0.1,-0.2,0.3],\"orientation\":[0,0,0,2]}", PROTO_MOTION);
    assert_true(msg.u.motion.has_t);
    assert_true(msg.u.motion.t == 1234.5);
    assert_true(fabsf(msg.u.motion.position.y + 0.2f) < 1e-7f);
    assert_true(msg.u.motion.orientation.w == 1.0f); /* normalized */
    expect_ok("{\"type\":\"motion\",\"position\":[0,0,0],\"orientation\":[0.5,0.5,0.5,0.5]}", PROTO_MOTION);
    assert_false(msg.u.motion.has_t);

    expect_err("{\"type\":\"motion\",\"orientation\":[0,0,0,1]}", PROTO_ERR_BAD_FIELD, "position");
    expect_err("{\"type\":\"motion\",\"position\":[0,0],\"orientation\":[0,0,0,1]}", PROTO_ERR_BAD_FIELD, "position");
    expect_err("{\"type\":\"motion\",\"position\":[0,0,0,0],\"orientation\":[0,0,0,1]}", PROTO_ERR_BAD_FIELD, "position");
    expect_err("{\"type\":\"motion\",\"position\":{\"x\":0},\"orientation\":[0,0,0,1]}", PROTO_ERR_BAD_FIELD, "position");
    expect_err("{\"type\":\"motion\",\"position\":[0,\"1\",0],\"orientation\":[0,0,0,1]}", PROTO_ERR_BAD_FIELD, "position[1]");
    expect_err("{\"type\":\"motion\",\"position\":[0,0,1e400],\"orientation\":[0,0,0,1]}", PROTO_ERR_NOT_FINITE, "position[2]");
    expect_err("{\"type\":\"motion\",\"position\":[0,0,5.5],\"orientation\":[0,0,0,1]}", PROTO_ERR_OUT_OF_RANGE, "position[2]");
    expect_err("{\"type\":\"motion\",\"position\":[0,0,0],\"orientation\":[0,0,0,0]}", PROTO_ERR_OUT_OF_RANGE, "orientation");
    expect_err("{\"type\":\"motion\",\"position\":[0,0,0],\"orientation\":[1e200,1e200,0,0]}", PROTO_ERR_OUT_OF_RANGE,
               "orientation");
    expect_err("{\"type\":\"motion\",\"t\":\"now\",\"position\":[0,0,0],\"orientation\":[0,0,0,1]}", PROTO_ERR_BAD_FIELD, "t");
    expect_err("{\"type\":\"motion\",\"position\":[0,0,0],\"orientation\":[0,0,0,1],\"scale\":2}", PROTO_ERR_BAD_FIELD, "scale");
}

static void test_animate(void **state)
{
    (void)state;
    expect_ok("{\"type\":\"animate\",\"preset\":\"shake\",\"speed\":2.5}", PROTO_ANIMATE);
    assert_int_equal(msg.u.animate.preset, 2);
    assert_true(msg.u.animate.speed == 2.5);
    expect_ok("{\"type\":\"animate\",\"preset\":\"none\"}", PROTO_ANIMATE);
    assert_int_equal(msg.u.animate.preset, 0);
    assert_true(msg.u.animate.speed == 1.0);
    expect_err("{\"type\":\"animate\",\"preset\":\"moonwalk\"}", PROTO_ERR_OUT_OF_RANGE, "preset");
    assert_non_null(strstr(err.message, "nod")); /* lists the valid names */
    expect_err("{\"type\":\"animate\",\"preset\":3}", PROTO_ERR_BAD_FIELD, "preset");
    expect_err("{\"type\":\"animate\"}", PROTO_ERR_BAD_FIELD, "preset");
    expect_err("{\"type\":\"animate\",\"preset\":\"nod\",\"speed\":-1}", PROTO_ERR_OUT_OF_RANGE, "speed");
    expect_err("{\"type\":\"animate\",\"preset\":\"nod\",\"speed\":21}", PROTO_ERR_OUT_OF_RANGE, "speed");
}

static void test_step_errors(void **state)
{
    (void)state;
    expect_err("{\"type\":\"step\",\"count\":0}", PROTO_ERR_OUT_OF_RANGE, "count");
    expect_err("{\"type\":\"step\",\"count\":1001}", PROTO_ERR_OUT_OF_RANGE, "count");
    expect_err("{\"type\":\"step\",\"count\":1.5}", PROTO_ERR_BAD_FIELD, "count");
    expect_err("{\"type\":\"step\",\"count\":[1]}", PROTO_ERR_BAD_FIELD, "count");
    expect_err("{\"type\":\"pause\",\"count\":1}", PROTO_ERR_BAD_FIELD, "count");
}

static void test_set_groom(void **state)
{
    (void)state;
    expect_ok("{\"type\":\"set_groom\",\"style\":\"wavy\",\"strands\":1024,\"verts\":16,\"seed\":99}", PROTO_SET_GROOM);
    assert_false(msg.u.set_groom.is_file);
    assert_int_equal(msg.u.set_groom.style, 1);
    assert_int_equal(msg.u.set_groom.strands, 1024);
    assert_int_equal(msg.u.set_groom.verts, 16);
    assert_true(msg.u.set_groom.has_seed);
    assert_int_equal(msg.u.set_groom.seed, 99);
    expect_ok("{\"type\":\"set_groom\",\"style\":\"curly\"}", PROTO_SET_GROOM);
    assert_int_equal(msg.u.set_groom.strands, 0);
    expect_ok("{\"type\":\"set_groom\",\"file\":\"ratboy/Ratboy_mohawk.tfx\",\"verts\":24}", PROTO_SET_GROOM);
    assert_true(msg.u.set_groom.is_file);
    assert_string_equal(msg.u.set_groom.file, "ratboy/Ratboy_mohawk.tfx");

    expect_err("{\"type\":\"set_groom\"}", PROTO_ERR_BAD_FIELD, "style");
    expect_err("{\"type\":\"set_groom\",\"style\":\"wavy\",\"file\":\"a.tfx\"}", PROTO_ERR_BAD_FIELD, "file");
    expect_err("{\"type\":\"set_groom\",\"style\":\"bald\"}", PROTO_ERR_OUT_OF_RANGE, "style");
    expect_err("{\"type\":\"set_groom\",\"file\":\"../secret.tfx\"}", PROTO_ERR_BAD_FIELD, "file");
    expect_err("{\"type\":\"set_groom\",\"file\":\"a/../../b.tfx\"}", PROTO_ERR_BAD_FIELD, "file");
    expect_err("{\"type\":\"set_groom\",\"file\":\"/etc/passwd\"}", PROTO_ERR_BAD_FIELD, "file");
    expect_err("{\"type\":\"set_groom\",\"file\":\"a//b.tfx\"}", PROTO_ERR_BAD_FIELD, "file");
    expect_err("{\"type\":\"set_groom\",\"file\":\"./a.tfx\"}", PROTO_ERR_BAD_FIELD, "file");
    expect_err("{\"type\":\"set_groom\",\"file\":\"dir/\"}", PROTO_ERR_BAD_FIELD, "file");
    expect_err("{\"type\":\"set_groom\",\"file\":\"\"}", PROTO_ERR_BAD_FIELD, "file");
    expect_err("{\"type\":\"set_groom\",\"file\":\"a b.tfx\"}", PROTO_ERR_BAD_FIELD, "file");
    expect_err("{\"type\":\"set_groom\",\"file\":\"a\\\\b.tfx\"}", PROTO_ERR_BAD_FIELD, "file");
    expect_err("{\"type\":\"set_groom\",\"file\":\"caf\\u00e9.tfx\"}", PROTO_ERR_BAD_FIELD, "file");
    char big[400];
    snprintf(big, sizeof big, "{\"type\":\"set_groom\",\"file\":\"%0300d\"}", 0);
    expect_err(big, PROTO_ERR_TOO_LARGE, "file");
    expect_err("{\"type\":\"set_groom\",\"file\":\"a.tfx\",\"strands\":10}", PROTO_ERR_BAD_FIELD, "strands");
    expect_err("{\"type\":\"set_groom\",\"style\":\"wavy\",\"strands\":0}", PROTO_ERR_OUT_OF_RANGE, "strands");
    expect_err("{\"type\":\"set_groom\",\"style\":\"wavy\",\"verts\":1}", PROTO_ERR_OUT_OF_RANGE, "verts");
    expect_err("{\"type\":\"set_groom\",\"style\":\"wavy\",\"strands\":65536,\"verts\":256}", PROTO_ERR_TOO_LARGE, "strands");
    expect_err("{\"type\":\"set_groom\",\"style\":\"wavy\",\"seed\":-1}", PROTO_ERR_OUT_OF_RANGE, "seed");
    expect_err("{\"type\":\"set_groom\",\"style\":\"wavy\",\"seed\":9007199254740992}", PROTO_ERR_OUT_OF_RANGE, "seed");
    /* the seed a hello shows (the default one, over 2^32) can be sent back */
    expect_ok("{\"type\":\"set_groom\",\"style\":\"wavy\",\"seed\":104373592858645}", PROTO_SET_GROOM);
    assert_true(msg.u.set_groom.seed == 104373592858645ull);
    assert_int_equal(msg.u.set_groom.collider_mode, PROTO_COLLIDER_KEEP);

    /* collider: a mesh file name (the file rules), null (none), absent (keep) */
    expect_ok("{\"type\":\"set_groom\",\"file\":\"a.tfx\",\"collider\":\"ratboy/Ratboy_body.tfxmesh\"}", PROTO_SET_GROOM);
    assert_int_equal(msg.u.set_groom.collider_mode, PROTO_COLLIDER_FILE);
    assert_string_equal(msg.u.set_groom.collider, "ratboy/Ratboy_body.tfxmesh");
    expect_ok("{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":null}", PROTO_SET_GROOM);
    assert_int_equal(msg.u.set_groom.collider_mode, PROTO_COLLIDER_NONE);
    static const char *const bad_names[] = { "\"../x.obj\"", "\"a/../../x.obj\"", "\"/etc/passwd\"", "\"a//b.obj\"",
                                             "\"./a.obj\"", "\"\"", "\"a b.obj\"", "\"caf\\u00e9.obj\"", "7", "true",
                                             "[\"a.obj\"]", "\"a.obj\\u0000../../etc/passwd\"", "\"\\u0000\"" };
    for (size_t i = 0; i < sizeof bad_names / sizeof bad_names[0]; i++) {
        char text[160];
        snprintf(text, sizeof text, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":%s}", bad_names[i]);
        expect_err(text, PROTO_ERR_BAD_FIELD, "collider");
    }
    snprintf(big, sizeof big, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":\"%0300d\"}", 0);
    expect_err(big, PROTO_ERR_TOO_LARGE, "collider");
    /* a NUL cuts no name short anywhere: the groom file, a nested member, an id */
    expect_err("{\"type\":\"set_groom\",\"file\":\"a.tfx\\u0000/../b\"}", PROTO_ERR_BAD_FIELD, "file");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gra\\u0000vity\":1}}", PROTO_ERR_UNKNOWN_PARAM, "values.gra");
    expect_err("{\"id\":\"x\\u0000\",\"type\":\"reset\"}", PROTO_ERR_BAD_FIELD, "id");
    expect_ok("{\"id\":\"x\\\\u0000\",\"type\":\"reset\"}", PROTO_RESET); /* an escaped backslash, then "u0000" */
    assert_string_equal(msg.id.str, "x\\u0000");
}

static void test_subscribe(void **state)
{
    (void)state;
    expect_ok("{\"type\":\"subscribe\",\"stride\":4,\"max_error\":0.001,\"max_rate\":30}", PROTO_SUBSCRIBE);
    assert_true(msg.u.subscribe.has_stride && msg.u.subscribe.has_max_error && msg.u.subscribe.has_max_rate);
    assert_int_equal(msg.u.subscribe.stride, 4);
    assert_true(msg.u.subscribe.max_error == 0.001);
    assert_true(msg.u.subscribe.max_rate == 30.0);
    expect_ok("{\"type\":\"subscribe\",\"max_rate\":0}", PROTO_SUBSCRIBE);
    assert_false(msg.u.subscribe.has_stride);
    assert_true(msg.u.subscribe.has_max_rate);
    expect_err("{\"type\":\"subscribe\",\"stride\":0}", PROTO_ERR_OUT_OF_RANGE, "stride");
    expect_err("{\"type\":\"subscribe\",\"stride\":2.5}", PROTO_ERR_BAD_FIELD, "stride");
    expect_err("{\"type\":\"subscribe\",\"max_error\":0}", PROTO_ERR_OUT_OF_RANGE, "max_error");
    expect_err("{\"type\":\"subscribe\",\"max_error\":1}", PROTO_ERR_OUT_OF_RANGE, "max_error");
    expect_err("{\"type\":\"subscribe\",\"max_rate\":-5}", PROTO_ERR_OUT_OF_RANGE, "max_rate");
    expect_err("{\"type\":\"subscribe\",\"max_rate\":1e999}", PROTO_ERR_NOT_FINITE, "max_rate");
    expect_err("{\"type\":\"subscribe\",\"strands\":\"all\"}", PROTO_ERR_BAD_FIELD, "strands");
    /* the source: strands or the hair mesh; absent keeps the current one */
    assert_false(msg.u.subscribe.has_source);
    expect_ok("{\"type\":\"subscribe\",\"source\":\"hairmesh\",\"max_rate\":30}", PROTO_SUBSCRIBE);
    assert_true(msg.u.subscribe.has_source && msg.u.subscribe.source == PROTO_SOURCE_HAIRMESH);
    assert_string_equal(proto_source_name(msg.u.subscribe.source), "hairmesh");
    expect_ok("{\"type\":\"subscribe\",\"source\":\"strands\"}", PROTO_SUBSCRIBE);
    assert_true(msg.u.subscribe.has_source && msg.u.subscribe.source == PROTO_SOURCE_STRANDS);
    expect_err("{\"type\":\"subscribe\",\"source\":\"mesh\"}", PROTO_ERR_OUT_OF_RANGE, "source");
    assert_non_null(strstr(err.message, "strands, hairmesh"));
    expect_err("{\"type\":\"subscribe\",\"source\":2}", PROTO_ERR_BAD_FIELD, "source");
    expect_err("{\"type\":\"subscribe\",\"source\":\"hairmeshhairmeshhairmesh\"}", PROTO_ERR_TOO_LARGE, "source");
}

static void test_envelope_errors(void **state)
{
    (void)state;
    expect_err("", PROTO_ERR_BAD_JSON, "");
    expect_err("{", PROTO_ERR_BAD_JSON, "");
    expect_err("not json", PROTO_ERR_BAD_JSON, "");
    expect_err("[{\"type\":\"reset\"}]", PROTO_ERR_BAD_JSON, "");
    expect_err("null", PROTO_ERR_BAD_JSON, "");
    expect_err("42", PROTO_ERR_BAD_JSON, "");
    expect_err("\"reset\"", PROTO_ERR_BAD_JSON, "");
    expect_err("{\"type\":\"reset\"} {\"type\":\"reset\"}", PROTO_ERR_BAD_JSON, "");
    expect_err("{\"type\":\"reset\"}x", PROTO_ERR_BAD_JSON, "");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":NaN}}", PROTO_ERR_BAD_JSON, "");
    /* RFC 8259, which cJSON does not hold to: no byte-order mark, numbers in JSON's grammar */
    expect_err("\xEF\xBB\xBF{\"type\":\"reset\"}", PROTO_ERR_BAD_JSON, "");
    static const char *const bad_numbers[] = { "007", "-01", "00", "+1", ".5", "1.", "1.e3", "1e", "1e+", "-", "01.5" };
    for (size_t i = 0; i < sizeof bad_numbers / sizeof bad_numbers[0]; i++) {
        char msg[128];
        snprintf(msg, sizeof msg, "{\"type\":\"step\",\"count\":%s}", bad_numbers[i]);
        expect_err(msg, PROTO_ERR_BAD_JSON, "");
        snprintf(msg, sizeof msg, "{\"type\":\"reset\",\"id\":%s}", bad_numbers[i]);
        expect_err(msg, PROTO_ERR_BAD_JSON, "");
    }
    static const char *const good_numbers[] = { "0", "-0", "7", "10", "0.5", "1e2", "1E+2", "2e-0", "-0.0e0" };
    for (size_t i = 0; i < sizeof good_numbers / sizeof good_numbers[0]; i++) {
        char msg[128];
        snprintf(msg, sizeof msg, "{\"type\":\"reset\",\"id\":%s}", good_numbers[i]);
        expect_ok(msg, PROTO_RESET);
    }
    /* digits inside strings are not numbers */
    expect_ok("{\"type\":\"reset\",\"id\":\"007+.5e\\\"01\"}", PROTO_RESET);
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":Infinity}}", PROTO_ERR_BAD_JSON, "");
    expect_err("{\"type\":\"set_params\",\"values\":{\"gravity\":-Infinity}}", PROTO_ERR_BAD_JSON, "");
    expect_err("{'type':'reset'}", PROTO_ERR_BAD_JSON, "");
    expect_err("{}", PROTO_ERR_BAD_FIELD, "type");
    expect_err("{\"type\":5}", PROTO_ERR_BAD_FIELD, "type");
    expect_err("{\"type\":null}", PROTO_ERR_BAD_FIELD, "type");
    expect_err("{\"type\":\"dance\"}", PROTO_ERR_UNKNOWN_TYPE, "type");
    expect_err("{\"type\":\"RESET\"}", PROTO_ERR_UNKNOWN_TYPE, "type");
    expect_err("{\"type\":\"reset\",\"extra\":1}", PROTO_ERR_BAD_FIELD, "extra");
    expect_err("{\"type\":\"reset\",\"type\":\"pause\"}", PROTO_ERR_BAD_FIELD, "type");
    /* ids */
    expect_err("{\"type\":\"reset\",\"id\":{}}", PROTO_ERR_BAD_FIELD, "id");
    expect_err("{\"type\":\"reset\",\"id\":[1]}", PROTO_ERR_BAD_FIELD, "id");
    expect_err("{\"type\":\"reset\",\"id\":true}", PROTO_ERR_BAD_FIELD, "id");
    expect_err("{\"type\":\"reset\",\"id\":1e999}", PROTO_ERR_NOT_FINITE, "id");
    char longid[200];
    snprintf(longid, sizeof longid, "{\"type\":\"reset\",\"id\":\"%065d\"}", 0);
    expect_err(longid, PROTO_ERR_TOO_LARGE, "id");
    /* the id is kept for the error reply when the rest is bad */
    expect_err("{\"id\":\"q1\",\"type\":\"dance\"}", PROTO_ERR_UNKNOWN_TYPE, "type");
    assert_int_equal(msg.id.kind, PROTO_ID_STRING);
    assert_string_equal(msg.id.str, "q1");
}

static void test_hostile_inputs(void **state)
{
    (void)state;
    /* deep nesting: refused by the parser's depth limit, without a crash */
    size_t depth = 5000;
    char *deep = malloc(2 * depth + 64);
    size_t n = (size_t)sprintf(deep, "{\"type\":\"reset\",\"x\":");
    for (size_t i = 0; i < depth; i++) deep[n++] = '[';
    for (size_t i = 0; i < depth; i++) deep[n++] = ']';
    deep[n++] = '}';
    assert_int_equal(proto_parse(&parser, deep, n, &msg, &err), CORE_EINVAL);
    assert_int_equal(err.code, PROTO_ERR_BAD_JSON);
    /* moderately deep but valid JSON in an unknown field: a field error */
    n = (size_t)sprintf(deep, "{\"type\":\"reset\",\"x\":");
    for (size_t i = 0; i < 100; i++) deep[n++] = '[';
    for (size_t i = 0; i < 100; i++) deep[n++] = ']';
    deep[n++] = '}';
    assert_int_equal(proto_parse(&parser, deep, n, &msg, &err), CORE_EINVAL);
    assert_int_equal(err.code, PROTO_ERR_BAD_FIELD);
    free(deep);

    /* oversize message */
    size_t big = PROTO_MAX_MESSAGE + 10;
    char *huge = malloc(big);
    memset(huge, ' ', big);
    memcpy(huge, "{\"type\":\"reset\"}", 16);
    assert_int_equal(proto_parse(&parser, huge, big, &msg, &err), CORE_EINVAL);
    assert_int_equal(err.code, PROTO_ERR_TOO_LARGE);
    /* just under the limit with trailing whitespace is fine */
    assert_int_equal(proto_parse(&parser, huge, PROTO_MAX_MESSAGE, &msg, &err), CORE_OK);
    free(huge);

    /* not NUL-terminated: only len bytes are read */
    const char buf[] = "{\"type\":\"reset\"}GARBAGE";
    assert_int_equal(proto_parse(&parser, buf, 16, &msg, &err), CORE_OK);
    /* embedded NUL */
    const char nul[] = "{\"type\":\"reset\"}\0{}";
    assert_int_equal(proto_parse(&parser, nul, sizeof nul - 1, &msg, &err), CORE_EINVAL);
    assert_int_equal(err.code, PROTO_ERR_BAD_JSON);

    /* huge numbers */
    expect_err("{\"type\":\"step\",\"count\":123456789012345678901234567890}", PROTO_ERR_OUT_OF_RANGE, "count");
    expect_err("{\"type\":\"step\",\"count\":-9e307}", PROTO_ERR_OUT_OF_RANGE, "count");
    expect_ok("{\"type\":\"set_params\",\"values\":{\"gravity\":1e-320}}", PROTO_SET_PARAMS);

    /* many fields */
    char many[1024];
    n = (size_t)sprintf(many, "{\"type\":\"reset\"");
    for (int i = 0; i < 40; i++) n += (size_t)sprintf(many + n, ",\"f%d\":%d", i, i);
    sprintf(many + n, "}");
    expect_err(many, PROTO_ERR_BAD_FIELD, "f0");

    /* unicode: escapes and raw UTF-8 in ids round-trip; lone surrogates are bad JSON */
    expect_ok("{\"type\":\"reset\",\"id\":\"h\\u00e9llo \\ud83d\\ude00 \xe2\x82\xac\"}", PROTO_RESET);
    assert_string_equal(msg.id.str, "h\xc3\xa9llo \xf0\x9f\x98\x80 \xe2\x82\xac");
    cJSON *j = json(proto_build_ok(&msg.id, PROTO_RESET, 0));
    assert_string_equal(str_of(j, "id"), "h\xc3\xa9llo \xf0\x9f\x98\x80 \xe2\x82\xac");
    cJSON_Delete(j);
    expect_err("{\"type\":\"reset\",\"id\":\"\\ud800\"}", PROTO_ERR_BAD_JSON, "");
    expect_ok("{\"type\":\"r\\u0065set\",\"id\":\"x\"}", PROTO_RESET); /* escapes in names are decoded */

    /* client names cut inside a character for the error message: the reply is still UTF-8 */
    static const char *const cut[] = {
        "{\"type\":\"%s\xc3\xa9\xc3\xa9\"}",                     /* unknown type, "%.64s" */
        "{\"type\":\"reset\",\"%s\xc3\xa9\xc3\xa9\":1}",           /* unknown field */
        "{\"type\":\"set_params\",\"values\":{\"%s\xc3\xa9\xc3\xa9\":1}}", /* unknown parameter */
        "{\"type\":\"animate\",\"preset\":\"%s\xc3\xa9\xc3\xa9\"}",   /* unknown preset, "%.48s" */
    };
    for (size_t i = 0; i < sizeof cut / sizeof cut[0]; i++)
        for (int pad = 40; pad <= 90; pad++) {
            char name[128], text[256];
            memset(name, 'a', (size_t)pad);
            name[pad] = 0;
            int len = snprintf(text, sizeof text, cut[i], name);
            assert_int_equal(proto_parse(&parser, text, (size_t)len, &msg, &err), CORE_EINVAL);
            char *reply = proto_build_error(&msg.id, &err);
            assert_non_null(reply);
            if (!core_utf8_valid(reply, strlen(reply))) fail_msg("case %zu, %d bytes: reply not UTF-8: %s", i, pad, reply);
            proto_free(reply);
        }
}

static void test_build_error_and_ok(void **state)
{
    (void)state;
    proto_id id = { .kind = PROTO_ID_NUMBER, .num = 42 };
    proto_error e;
    proto_fail(&e, PROTO_ERR_OUT_OF_RANGE, "values.gravity", "values.gravity = %g is outside [0, 50]", -1.0);
    cJSON *j = json(proto_build_error(&id, &e));
    assert_string_equal(str_of(j, "type"), "error");
    assert_true(num_of(j, "id") == 42.0);
    assert_string_equal(str_of(j, "code"), "out_of_range");
    assert_string_equal(str_of(j, "field"), "values.gravity");
    assert_non_null(strstr(str_of(j, "message"), "outside"));
    cJSON_Delete(j);

    proto_id none = { 0 };
    j = json(proto_build_ok(&none, PROTO_SET_PARAMS, 123456789012));
    assert_string_equal(str_of(j, "type"), "ok");
    assert_string_equal(str_of(j, "request"), "set_params");
    assert_true(num_of(j, "step") == 123456789012.0); /* where the change shows */
    assert_null(cJSON_GetObjectItemCaseSensitive(j, "id"));
    cJSON_Delete(j);
    char *text = proto_build_ok(&id, PROTO_RESET, 77);
    uint64_t step = 0;
    assert_int_equal(proto_read_ok_step(text, strlen(text), &step), CORE_OK);
    assert_true(step == 77);
    proto_free(text);
    static const char *const no_step[] = { "{\"type\":\"ok\",\"request\":\"keyframe\"}",
                                           "{\"type\":\"ok\",\"step\":-1}", "{\"type\":\"ok\",\"step\":1.5}",
                                           "{\"type\":\"state\",\"step\":3}", "not json" };
    for (size_t i = 0; i < sizeof no_step / sizeof no_step[0]; i++)
        assert_int_equal(proto_read_ok_step(no_step[i], strlen(no_step[i]), &step), CORE_EFORMAT);
    j = json(proto_build_ok(&id, PROTO_KEYFRAME, -1)); /* changes no simulation: no step */
    assert_null(cJSON_GetObjectItemCaseSensitive(j, "step"));
    assert_true(num_of(j, "id") == 42.0);
    cJSON_Delete(j);

    for (int c = PROTO_ERR_BAD_JSON; c <= PROTO_ERR_FAILED; c++) assert_string_not_equal(proto_code_name((proto_code)c), "unknown");
    for (int t = PROTO_GET_PARAMS; t <= PROTO_KEYFRAME; t++) assert_string_not_equal(proto_type_name((proto_type)t), "unknown");
}

static void test_build_params(void **state)
{
    (void)state;
    test_params v = { 9.81f, 3, true, 0.2f };
    proto_id id = { .kind = PROTO_ID_STRING, .str = "g" };
    cJSON *j = json(proto_build_params(&id, table, 4, &v, NULL, -1));
    assert_string_equal(str_of(j, "type"), "params");
    assert_string_equal(str_of(j, "id"), "g");
    assert_true(cJSON_IsNull(cJSON_GetObjectItemCaseSensitive(j, "by")));
    const cJSON *vals = cJSON_GetObjectItemCaseSensitive(j, "values");
    assert_true(num_of(vals, "gravity") == 9.81); /* shortest float form, not 9.8100004196 */
    assert_true(num_of(vals, "substeps") == 3.0);
    assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(vals, "sph")));
    assert_true(num_of(vals, "stiffness") == 0.2);
    assert_null(cJSON_GetObjectItemCaseSensitive(j, "changed"));
    cJSON_Delete(j);

    /* an announcement: every value (it may replace an older one in a client's queue), and
     * the names of what changed */
    bool changed[4] = { true, false, true, false };
    j = json(proto_build_params(NULL, table, 4, &v, changed, 3));
    vals = cJSON_GetObjectItemCaseSensitive(j, "values");
    assert_int_equal(cJSON_GetArraySize(vals), 4);
    assert_true(num_of(vals, "substeps") == 3.0);
    const cJSON *names = cJSON_GetObjectItemCaseSensitive(j, "changed");
    assert_int_equal(cJSON_GetArraySize(names), 2);
    assert_string_equal(cJSON_GetArrayItem(names, 0)->valuestring, "gravity");
    assert_string_equal(cJSON_GetArrayItem(names, 1)->valuestring, "sph");
    assert_true(num_of(j, "by") == 3.0);
    cJSON_Delete(j);
}

static void make_groom(core_groom *g)
{
    core_err e;
    assert_int_equal(core_groom_alloc(g, 3, 4, &e), CORE_OK);
    for (uint32_t s = 0; s < 3; s++)
        for (uint32_t k = 0; k < 4; k++) {
            float *p = g->pos + 3 * (s * 4 + k);
            p[0] = 0.1f * (float)s;
            p[1] = -0.01f * (float)k * (float)(s + 1);
            p[2] = 0.05f;
        }
    g->ncolliders = 3;
    g->colliders[0] = (core_collider){ .kind = CORE_COLLIDER_SPHERE, .a = { 0, 0.1f, 0 }, .radius = 0.09f };
    g->colliders[1] = (core_collider){ .kind = CORE_COLLIDER_CAPSULE, .a = { 0, -0.1f, 0 }, .b = { 0, -0.3f, 0 }, .radius = 0.05f };
    g->colliders[2] = (core_collider){ .kind = CORE_COLLIDER_ELLIPSOID, .a = { 0, 0, 0 }, .radii = { 0.08f, 0.1f, 0.09f },
                                       .rot = { 0, 0, 0, 1 } };
}

static void test_build_hello_and_groom(void **state)
{
    (void)state;
    core_groom g = { 0 };
    make_groom(&g);
    proto_groom pg = { "procedural:straight", &g, 7, NULL, NULL, NULL };
    proto_groom_json gj;
    core_err cerr;
    assert_int_equal(proto_groom_json_build(&gj, &pg, &cerr), CORE_EINVAL); /* the data must be described */
    proto_data_ref dr = { "/groom.bin", "fedcba9876543210", 64 };
    pg.data = &dr;
    assert_int_equal(proto_groom_json_build(&gj, &pg, &cerr), CORE_OK);
    test_params v = { 0.0f, 2, false, 0.1f };
    static const char *const files[] = { "ratboy/Ratboy_mohawk.tfx" };
    proto_hello h = {
        .server = "strandcastd", .version = "0.1.0", .client = 5, .groom = &gj, .head = core_xform_identity(),
        .params = table, .nparams = 4, .values = &v, .presets = presets, .npresets = 4,
        .animation = { "nod", 2.0 }, .styles = styles, .nstyles = 3, .files = files, .nfiles = 1,
        .stream = { "strand", 1, 3, 1e-4, 0, 60, 60, 30 }, .state = { true, 1.5, 90, { "nod", 2.0 } },
    };
    /* what a client tool reads back of it */
    char *text = proto_build_hello(&h);
    proto_hello_info hi;
    assert_int_equal(proto_read_hello(text, strlen(text), &hi, &cerr), CORE_OK);
    assert_string_equal(hi.server, "strandcastd");
    assert_string_equal(hi.version, "0.1.0");
    assert_true(hi.protocol == PROTO_VERSION && hi.client == 5 && hi.strands == 3 && hi.verts == 4);
    assert_true(hi.stride == 1 && hi.max_error == 1e-4 && hi.rate == 60 && hi.frame_rate == 60);
    proto_free(text);
    static const char *const not_hello[] = { "{\"type\":\"ok\"}", "{\"type\":\"hello\",\"protocol\":2}", "{\"type\":\"hel" };
    for (size_t i = 0; i < 3; i++)
        assert_int_equal(proto_read_hello(not_hello[i], strlen(not_hello[i]), &hi, &cerr), CORE_EFORMAT);
    cJSON *j = json(proto_build_hello(&h));
    assert_string_equal(str_of(j, "type"), "hello");
    assert_string_equal(str_of(j, "subprotocol"), PROTO_SUBPROTOCOL);
    assert_true(num_of(j, "protocol") == PROTO_VERSION);
    assert_true(num_of(j, "client") == 5.0);
    const cJSON *gr = cJSON_GetObjectItemCaseSensitive(j, "groom");
    assert_string_equal(str_of(gr, "source"), "procedural:straight");
    assert_true(num_of(gr, "strands") == 3 && num_of(gr, "verts") == 4 && num_of(gr, "seed") == 7);
    /* the per-strand arrays are not in the JSON: it says where their binary is */
    assert_null(cJSON_GetObjectItemCaseSensitive(gr, "rest_lengths"));
    assert_null(cJSON_GetObjectItemCaseSensitive(gr, "roots"));
    assert_string_equal(str_of(gr, "url"), "/groom.bin");
    assert_string_equal(str_of(gr, "etag"), "fedcba9876543210");
    assert_true(num_of(gr, "bytes") == 64);
    assert_true(cJSON_IsNull(cJSON_GetObjectItemCaseSensitive(gr, "hairmesh"))); /* a strand groom */
    const cJSON *bounds = cJSON_GetObjectItemCaseSensitive(gr, "bounds");
    assert_true(fabs(cJSON_GetArrayItem(bounds, 1)->valuedouble + 0.09) < 1e-6 && cJSON_GetArrayItem(bounds, 4)->valuedouble == 0.0);
    const cJSON *col = cJSON_GetObjectItemCaseSensitive(j, "colliders");
    assert_int_equal(cJSON_GetArraySize(col), 3);
    assert_string_equal(str_of(cJSON_GetArrayItem(col, 0), "kind"), "sphere");
    assert_true(num_of(cJSON_GetArrayItem(col, 0), "radius") == 0.09);
    assert_string_equal(str_of(cJSON_GetArrayItem(col, 1), "kind"), "capsule");
    assert_string_equal(str_of(cJSON_GetArrayItem(col, 2), "kind"), "ellipsoid");
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(col, 2), "rotation")), 4);
    const cJSON *params = cJSON_GetObjectItemCaseSensitive(j, "params");
    const cJSON *schema = cJSON_GetObjectItemCaseSensitive(params, "schema");
    assert_int_equal(cJSON_GetArraySize(schema), 4);
    const cJSON *s0 = cJSON_GetArrayItem(schema, 0);
    assert_string_equal(str_of(s0, "name"), "gravity");
    assert_string_equal(str_of(s0, "type"), "float");
    assert_true(num_of(s0, "max") == 50.0 && num_of(s0, "default") == 9.81);
    assert_string_equal(str_of(s0, "unit"), "m/s^2");
    assert_string_equal(str_of(cJSON_GetArrayItem(schema, 3), "help"), "Stiffness \"quoted\".");
    /* the scale hint: "log" for a CORE_PARAM_LOG entry, absent (linear) for the others */
    assert_string_equal(str_of(cJSON_GetArrayItem(schema, 3), "scale"), "log");
    for (int i = 0; i < 3; i++) assert_null(cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(schema, i), "scale"));
    assert_true(cJSON_IsBool(cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(schema, 2), "default")));
    assert_true(num_of(cJSON_GetObjectItemCaseSensitive(params, "values"), "substeps") == 2.0);
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(j, "presets")), 4);
    const cJSON *grooms = cJSON_GetObjectItemCaseSensitive(j, "grooms");
    assert_string_equal(cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(grooms, "files"), 0)->valuestring, files[0]);
    const cJSON *stream = cJSON_GetObjectItemCaseSensitive(j, "stream");
    assert_string_equal(str_of(stream, "codec"), "strand");
    assert_true(num_of(stream, "frame_rate") == 60 && num_of(stream, "keyframe_interval") == 30);
    const cJSON *st = cJSON_GetObjectItemCaseSensitive(j, "state");
    assert_true(cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(st, "paused")));
    assert_true(num_of(st, "steps") == 90);
    assert_string_equal(str_of(cJSON_GetObjectItemCaseSensitive(st, "animation"), "preset"), "nod");
    assert_true(num_of(cJSON_GetObjectItemCaseSensitive(j, "limits"), "max_message") == PROTO_MAX_MESSAGE);
    cJSON_Delete(j);

    j = json(proto_build_groom(&gj));
    assert_string_equal(str_of(j, "type"), "groom");
    assert_true(num_of(cJSON_GetObjectItemCaseSensitive(j, "groom"), "strands") == 3);
    assert_int_equal(cJSON_GetArraySize(cJSON_GetObjectItemCaseSensitive(j, "colliders")), 3);
    assert_true(cJSON_IsNull(cJSON_GetObjectItemCaseSensitive(j, "collider_mesh")));
    cJSON_Delete(j);
    proto_groom_json_free(&gj);

    /* with a collision mesh (a tetrahedron) and its grid: described in hello and groom */
    g.mesh = calloc(1, sizeof *g.mesh);
    assert_int_equal(core_mesh_alloc(g.mesh, 4, 4, &cerr), CORE_OK);
    static const float tp[12] = { 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1 };
    static const uint32_t tt[12] = { 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3 };
    memcpy(g.mesh->pos, tp, sizeof tp);
    memcpy(g.mesh->tri, tt, sizeof tt);
    g.sdf = calloc(1, sizeof *g.sdf);
    uint32_t dims[3] = { 2, 3, 4 };
    assert_int_equal(core_sdf_alloc(g.sdf, dims, core_v3(-0.5f, 0, 0), 0.25f, &cerr), CORE_OK);
    proto_mesh_ref mr = { "ratboy/tet.obj", "/collider.bin", "0123456789abcdef", 160 };
    pg.mesh = &mr;
    assert_int_equal(proto_groom_json_build(&gj, &pg, &cerr), CORE_OK);
    h.groom = &gj;
    static const char *const meshes[] = { "ratboy/tet.obj" };
    h.meshes = meshes;
    h.nmeshes = 1;
    j = json(proto_build_hello(&h));
    const cJSON *cm = cJSON_GetObjectItemCaseSensitive(j, "collider_mesh");
    assert_string_equal(str_of(cm, "source"), "ratboy/tet.obj");
    assert_true(num_of(cm, "verts") == 4 && num_of(cm, "triangles") == 4 && num_of(cm, "bytes") == 160);
    assert_string_equal(str_of(cm, "url"), "/collider.bin");
    assert_string_equal(str_of(cm, "etag"), "0123456789abcdef");
    const cJSON *mb = cJSON_GetObjectItemCaseSensitive(cm, "bounds");
    assert_true(cJSON_GetArrayItem(mb, 0)->valuedouble == 0 && cJSON_GetArrayItem(mb, 5)->valuedouble == 1);
    const cJSON *sd = cJSON_GetObjectItemCaseSensitive(cm, "sdf");
    assert_true(num_of(sd, "cell") == 0.25);
    assert_true(cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(sd, "dims"), 2)->valuedouble == 4);
    assert_true(cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(sd, "origin"), 0)->valuedouble == -0.5);
    grooms = cJSON_GetObjectItemCaseSensitive(j, "grooms");
    assert_string_equal(cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(grooms, "colliders"), 0)->valuestring, meshes[0]);
    cJSON_Delete(j);
    j = json(proto_build_groom(&gj));
    assert_true(num_of(cJSON_GetObjectItemCaseSensitive(j, "collider_mesh"), "triangles") == 4);
    cJSON_Delete(j);
    proto_groom_json_free(&gj);

    /* the binary: 16-byte header, float32 positions, uint32 indices, little-endian */
    size_t n = proto_mesh_bin_size(g.mesh);
    assert_int_equal(n, 16 + 48 + 48);
    unsigned char bin[112];
    proto_mesh_bin_write(g.mesh, bin);
    assert_memory_equal(bin, "SCMH\1\0\0\0\4\0\0\0\4\0\0\0", 16);
    float f;
    memcpy(&f, bin + 16 + 4 * 3, 4);
    assert_true(f == 1.0f);
    assert_int_equal(bin[16 + 48 + 4], 2); /* tri[1] */
    uint32_t nv, nt;
    assert_int_equal(proto_mesh_bin_read(bin, n, &nv, &nt, &cerr), CORE_OK);
    assert_true(nv == 4 && nt == 4);
    char tag[17], tag2[17];
    proto_bin_etag(bin, n, tag);
    assert_int_equal(strlen(tag), 16);
    assert_int_equal(proto_mesh_bin_read(bin, n - 1, &nv, &nt, &cerr), CORE_EFORMAT); /* short */
    bin[16 + 48] = 4;                                                                    /* index out of range */
    assert_int_equal(proto_mesh_bin_read(bin, n, &nv, &nt, &cerr), CORE_EFORMAT);
    assert_non_null(strstr(cerr.msg, "vertex 4"));
    proto_bin_etag(bin, n, tag2);
    assert_string_not_equal(tag, tag2); /* the tag follows the bytes */
    bin[16 + 48] = 0;
    memset(bin + 16, 0xff, 4); /* a NaN position */
    assert_int_equal(proto_mesh_bin_read(bin, n, &nv, &nt, &cerr), CORE_EFORMAT);
    bin[4] = 2; /* version */
    assert_int_equal(proto_mesh_bin_read(bin, n, &nv, &nt, &cerr), CORE_EFORMAT);
    core_groom_free(&g);
}

/* The groom data binary: header, rest segment lengths, roots (little-endian float32). */
static void test_groom_bin(void **state)
{
    (void)state;
    core_groom g = { 0 };
    make_groom(&g);
    size_t n = proto_groom_bin_size(&g);
    assert_int_equal(n, 16 + 16 * 3);
    unsigned char bin[64];
    proto_groom_bin_write(&g, bin);
    assert_memory_equal(bin, "SCGR\1\0\0\0\3\0\0\0\4\0\0\0", 16);
    float f;
    memcpy(&f, bin + 16 + 4 * 2, 4); /* strand 2: segments of 0.03 m */
    assert_true(fabsf(f - 0.03f) < 1e-6f);
    memcpy(&f, bin + 16 + 12 + 12 * 1, 4); /* strand 1's root x */
    assert_true(f == 0.1f);
    memcpy(&f, bin + 16 + 12 + 12 * 2 + 8, 4); /* strand 2's root z */
    assert_true(f == 0.05f);
    uint32_t ns, nv;
    core_err cerr;
    assert_int_equal(proto_groom_bin_read(bin, n, &ns, &nv, &cerr), CORE_OK);
    assert_true(ns == 3 && nv == 4);
    assert_int_equal(proto_groom_bin_read(bin, n - 4, &ns, &nv, &cerr), CORE_EFORMAT); /* short */
    assert_non_null(strstr(cerr.msg, "3 strands need 64 bytes"));
    memset(bin + 16 + 4, 0xff, 4); /* a NaN rest length */
    assert_int_equal(proto_groom_bin_read(bin, n, &ns, &nv, &cerr), CORE_EFORMAT);
    assert_non_null(strstr(cerr.msg, "strand 1's rest length"));
    proto_groom_bin_write(&g, bin);
    memset(bin + 16 + 12 + 12 * 2 + 4, 0xff, 4); /* a NaN root */
    assert_int_equal(proto_groom_bin_read(bin, n, &ns, &nv, &cerr), CORE_EFORMAT);
    assert_non_null(strstr(cerr.msg, "strand 2's root"));
    proto_groom_bin_write(&g, bin);
    bin[12] = 1; /* one vertex per strand */
    assert_int_equal(proto_groom_bin_read(bin, n, &ns, &nv, &cerr), CORE_EFORMAT);
    bin[12] = 4;
    bin[0] = 'X';
    assert_int_equal(proto_groom_bin_read(bin, n, &ns, &nv, &cerr), CORE_EFORMAT);
    bin[0] = 'S';
    bin[4] = 2; /* version */
    assert_int_equal(proto_groom_bin_read(bin, n, &ns, &nv, &cerr), CORE_EFORMAT);
    core_groom_free(&g);
}

/* A hair mesh of 5 columns x 3 layers: a quad (0 1 2 3) and a triangle (1 4 2), two guides. */
static uint32_t hm_faces[8] = { 0, 1, 2, 3, 1, 4, 2, CORE_HAIRMESH_NONE };
static uint32_t hm_gface[2] = { 0, 1 };
static float hm_guv[4] = { 0.25f, 0.5f, 0.2f, 0.3f };
static float hm_pos[45];

static core_hairmesh hand_hairmesh(void)
{
    for (int i = 0; i < 45; i++) hm_pos[i] = 0.01f * (float)i;
    return (core_hairmesh){ .ncols = 5, .nlayers = 3, .pos = hm_pos, .nfaces = 2, .faces = hm_faces, .nguides = 2,
                            .guide_face = hm_gface, .guide_uv = hm_guv };
}

/* The hair mesh topology binary: header, faces, guides, rest vertices; every inconsistency
 * refused with the reason. */
static void test_hairmesh_bin(void **state)
{
    (void)state;
    core_hairmesh m = hand_hairmesh();
    size_t n = proto_hairmesh_bin_size(&m);
    assert_int_equal(n, 24 + 16 * 2 + 12 * 2 + 12 * 15);
    unsigned char bin[24 + 32 + 24 + 180];
    proto_hairmesh_bin_write(&m, bin);
    assert_memory_equal(bin, "SCHT\1\0\0\0\5\0\0\0\3\0\0\0\2\0\0\0\2\0\0\0", 24);
    assert_memory_equal(bin + 24 + 16 + 12, "\xff\xff\xff\xff", 4); /* the triangle's 4th corner */
    float f;
    memcpy(&f, bin + 24 + 32 + 8 + 4 * 3, 4); /* guide 1's v */
    assert_true(f == 0.3f);
    memcpy(&f, bin + 24 + 32 + 24 + 4 * 44, 4); /* column 4, layer 2, z */
    assert_true(f == 0.44f);
    proto_hairmesh_counts c;
    core_err cerr;
    assert_int_equal(proto_hairmesh_bin_read(bin, n, &c, &cerr), CORE_OK);
    assert_true(c.ncols == 5 && c.nlayers == 3 && c.nfaces == 2 && c.nguides == 2);
    assert_int_equal(proto_hairmesh_bin_read(bin, n - 4, &c, &cerr), CORE_EFORMAT); /* short */
    assert_non_null(strstr(cerr.msg, "need 260 bytes, got 256"));
    assert_int_equal(proto_hairmesh_bin_read(bin, 20, &c, &cerr), CORE_EFORMAT);
    static const struct {
        size_t at;
        uint32_t value;
        const char *why;
    } bad[] = {
        { 24 + 4, 9, "face 0 corner 1 is column 9, past the 5 columns" },
        { 24 + 8, 0, "face 0 uses column 0 twice" },
        { 24 + 16 + 12, 4, "face 1 uses column 4 twice" },
        { 24 + 32 + 4, 2, "guide 1 is in face 2, past the 2 faces" },
        { 24 + 32 + 8, 0x7fc00000u, "guide 0's coordinates are not finite" },
        { 24 + 32 + 24 + 4 * 40, 0x7f800000u, "column 4 layer 1 is not finite" },
        { 12, 1, "1 layers" },
        { 8, 0, "0 columns" },
        { 4, 2, "version 2" },
        { 0, 0x54484358u, "without the \"SCHT\" header" },
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        proto_hairmesh_bin_write(&m, bin);
        for (int k = 0; k < 4; k++) bin[bad[i].at + (size_t)k] = (unsigned char)(bad[i].value >> (8 * k));
        assert_int_equal(proto_hairmesh_bin_read(bin, n, &c, &cerr), CORE_EFORMAT);
        if (!strstr(cerr.msg, bad[i].why)) fail_msg("case %zu: %s", i, cerr.msg);
        assert_true(c.ncols == 0 && c.nfaces == 0);
    }
}

/* A groom traced through a hair mesh names the topology binary in its JSON. */
static void test_groom_json_hairmesh(void **state)
{
    (void)state;
    core_groom g = { 0 };
    make_groom(&g);
    core_hairmesh m = hand_hairmesh();
    g.hairmesh = &m;
    proto_data_ref dr = { "/groom.bin", "fedcba9876543210", 64 };
    proto_groom pg = { "hairmesh:test", &g, 7, &dr, NULL, NULL };
    proto_groom_json gj;
    core_err cerr;
    assert_int_equal(proto_groom_json_build(&gj, &pg, &cerr), CORE_EINVAL);
    assert_non_null(strstr(cerr.msg, "hair mesh binary"));
    proto_data_ref hr = { "/hairmesh.bin", "0123456789abcdef", 260 };
    pg.hairmesh = &hr;
    assert_int_equal(proto_groom_json_build(&gj, &pg, &cerr), CORE_OK);
    cJSON *j = json(proto_build_groom(&gj));
    const cJSON *h = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(j, "groom"), "hairmesh");
    assert_true(num_of(h, "ncols") == 5 && num_of(h, "nlayers") == 3 && num_of(h, "nfaces") == 2 && num_of(h, "nguides") == 2);
    assert_string_equal(str_of(h, "url"), "/hairmesh.bin");
    assert_string_equal(str_of(h, "etag"), "0123456789abcdef");
    assert_true(num_of(h, "bytes") == 260);
    cJSON_Delete(j);
    proto_groom_json_free(&gj);
    g.hairmesh = NULL; /* the mesh's arrays are static */
    core_groom_free(&g);
}

static void test_read_envelope(void **state)
{
    (void)state;
    char type[16];
    proto_id id, want = { .kind = PROTO_ID_STRING, .str = "s1" };
    const char *m = "{\"type\":\"subscribed\",\"id\":\"s1\",\"stream\":{}}";
    assert_int_equal(proto_read_envelope(m, strlen(m), type, sizeof type, &id), CORE_OK);
    assert_string_equal(type, "subscribed");
    assert_true(proto_id_equal(&id, &want));
    want.str[1] = '2';
    assert_false(proto_id_equal(&id, &want));
    m = "{\"type\":\"ok\",\"id\":7}";
    assert_int_equal(proto_read_envelope(m, strlen(m), type, sizeof type, &id), CORE_OK);
    proto_id seven = { .kind = PROTO_ID_NUMBER, .num = 7 };
    assert_true(proto_id_equal(&id, &seven));
    assert_false(proto_id_equal(&id, &want));
    m = "{\"type\":\"stats\",\"id\":[1]}"; /* an id that is no id */
    assert_int_equal(proto_read_envelope(m, strlen(m), type, sizeof type, &id), CORE_OK);
    assert_int_equal(id.kind, PROTO_ID_NONE);
    m = "{\"type\":\"a-type-longer-than-the-buffer\"}";
    assert_int_equal(proto_read_envelope(m, strlen(m), type, sizeof type, &id), CORE_OK);
    assert_int_equal(strlen(type), sizeof type - 1);
    assert_int_equal(proto_read_envelope("[1,2]", 5, type, sizeof type, &id), CORE_EFORMAT);
    assert_string_equal(type, "");
    assert_int_equal(proto_read_envelope("{\"type\":", 8, type, sizeof type, &id), CORE_EFORMAT);
}

static void test_build_state_stats_subscribed(void **state)
{
    (void)state;
    proto_state s = { false, 2.25, 135, { "shake", 1.5 } };
    proto_id id = { .kind = PROTO_ID_NUMBER, .num = 3 };
    cJSON *j = json(proto_build_state(&id, &s));
    assert_string_equal(str_of(j, "type"), "state");
    assert_true(cJSON_IsFalse(cJSON_GetObjectItemCaseSensitive(j, "paused")));
    assert_true(num_of(j, "sim_time") == 2.25);
    assert_string_equal(str_of(cJSON_GetObjectItemCaseSensitive(j, "animation"), "preset"), "shake");
    cJSON_Delete(j);

    proto_stats st = { 59.5, 4.25, 0.5, 3, 10.0, 600, 1 };
    j = json(proto_build_stats(&st));
    assert_string_equal(str_of(j, "type"), "stats");
    assert_true(num_of(j, "steps_per_s") == 59.5 && num_of(j, "clients") == 3 && num_of(j, "nan_resets") == 1);
    cJSON_Delete(j);

    proto_stream ps = { "strand", 4, 1024, 0.001, 25, 60, 30, 30 };
    j = json(proto_build_subscribed(&id, &ps));
    assert_string_equal(str_of(j, "type"), "subscribed");
    const cJSON *so = cJSON_GetObjectItemCaseSensitive(j, "stream");
    assert_true(num_of(so, "stride") == 4 && num_of(so, "strands") == 1024 && num_of(so, "max_rate") == 25);
    assert_true(num_of(so, "rate") == 60 && num_of(so, "frame_rate") == 30 && num_of(so, "keyframe_interval") == 30);
    cJSON_Delete(j);
}

/* Room names (charset, length) and the room a WebSocket path names. */
static void test_rooms(void **state)
{
    (void)state;
    assert_true(proto_room_valid("a"));
    assert_true(proto_room_valid("Studio_2-b"));
    char name[PROTO_MAX_ROOM + 2];
    memset(name, 'x', sizeof name);
    name[PROTO_MAX_ROOM] = '\0';
    assert_true(proto_room_valid(name));
    name[PROTO_MAX_ROOM] = 'x';
    name[PROTO_MAX_ROOM + 1] = '\0';
    assert_false(proto_room_valid(name));
    static const char *const bad[] = { "", "a.b", "a b", "a*", "a>", "r\xc3\xa9", "a/b", "%41" };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) assert_false(proto_room_valid(bad[i]));
    char room[PROTO_MAX_ROOM + 1];
    proto_error e;
    assert_int_equal(proto_room_of_path("/", room, &e), CORE_OK);
    assert_string_equal(room, PROTO_DEFAULT_ROOM);
    assert_int_equal(proto_room_of_path("/rooms", room, &e), CORE_OK); /* not under /rooms/ */
    assert_string_equal(room, PROTO_DEFAULT_ROOM);
    assert_int_equal(proto_room_of_path("/rooms/studio", room, &e), CORE_OK);
    assert_string_equal(room, "studio");
    assert_int_equal(proto_room_of_path("/rooms/a.b\x01\xff", room, &e), CORE_EINVAL);
    assert_int_equal(e.code, PROTO_ERR_BAD_ROOM);
    assert_string_equal(e.field, "room");
    assert_non_null(strstr(e.message, "\"a.b??\""));
    assert_string_equal(proto_code_name(PROTO_ERR_BAD_ROOM), "bad_room");
    assert_string_equal(proto_code_name(PROTO_ERR_UNKNOWN_ROOM), "unknown_room");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_simple_messages),   cmocka_unit_test(test_set_params),
        cmocka_unit_test(test_motion),            cmocka_unit_test(test_enum_params),
                   cmocka_unit_test(test_animate),
        cmocka_unit_test(test_step_errors),       cmocka_unit_test(test_set_groom),
        cmocka_unit_test(test_subscribe),         cmocka_unit_test(test_envelope_errors),
        cmocka_unit_test(test_hostile_inputs),    cmocka_unit_test(test_build_error_and_ok),
        cmocka_unit_test(test_build_params),      cmocka_unit_test(test_build_hello_and_groom), cmocka_unit_test(test_groom_bin),
        cmocka_unit_test(test_hairmesh_bin),      cmocka_unit_test(test_groom_json_hairmesh),
        cmocka_unit_test(test_build_state_stats_subscribed),
        cmocka_unit_test(test_read_envelope),      cmocka_unit_test(test_rooms),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
