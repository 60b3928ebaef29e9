/* Tests for the record file format (app_rec) and the replay's checks (app_replay): every input
 * kind round-trips bit for bit; a file of another version, truncated, corrupt (crc32), with
 * records after the end or without one, with an unknown parameter or a value out of its range,
 * or naming a groom file or asset that is missing is refused naming the byte, the record and the
 * field; the digest sees one flipped bit. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app/app_anim.h"
#include "app/app_rec.h"
#include "app/app_replay.h"
#include "groom/groom.h"

typedef struct fixture {
    proto_parser p;
    const char *styles[3];
    app_rec_start start;
    app_rec_buf b;
} fixture;

static void setup_parser(fixture *f)
{
    memset(f, 0, sizeof *f);
    size_t n;
    const core_param_info *t = sim_param_table(&n);
    for (int i = 0; i < 3; i++) f->styles[i] = groom_style_name((groom_style)i);
    f->p = (proto_parser){ t, n, app_preset_names, APP_PRESET_COUNT, f->styles, 3 };
    snprintf(f->start.groom, sizeof f->start.groom, "wavy");
    f->start.strands = 64;
    f->start.verts = 12;
    f->start.seed = 1234567890123ull;
    f->start.backend = SIM_BACKEND_CPU;
    f->start.threads = 2;
    sim_params_default(&f->start.params);
    f->start.params.gravity = 3.25f;
    f->start.params.dt = 1.0f / 120.0f;
}

static size_t find_index(const proto_parser *p, const char *name)
{
    size_t i = 0;
    while (i < p->nparams && strcmp(p->params[i].name, name) != 0) i++;
    assert_true(i < p->nparams);
    return i;
}

/* A file: the start, one input of every kind, two digests, the end at step 40. */
static void write_file(fixture *f)
{
    app_rec_put_file_header(&f->b);
    app_rec_put_start(&f->b, &f->start, f->p.params, f->p.nparams);
    proto_msg m;
    memset(&m, 0, sizeof m);
    m.type = PROTO_SET_PARAMS;
    m.u.set_params.count = 2;
    m.u.set_params.v[0] = (proto_param_value){ (uint32_t)find_index(&f->p, "wind_x"), 1.0 / 3.0 };
    m.u.set_params.v[1] = (proto_param_value){ (uint32_t)find_index(&f->p, "gravity"), 7.5 };
    app_rec_put_input(&f->b, 3, &m, &f->p);
    memset(&m, 0, sizeof m);
    m.type = PROTO_MOTION;
    m.u.motion.position = (core_vec3){ 0.1f, -0.2f, 1.0f / 3.0f };
    m.u.motion.orientation = (core_quat){ 0.0f, 0.0871557f, 0.0f, 0.9961947f };
    app_rec_put_input(&f->b, 3, &m, &f->p);
    app_rec_put_digest(&f->b, 4, 0x0123456789abcdefull);
    memset(&m, 0, sizeof m);
    m.type = PROTO_ANIMATE;
    m.u.animate.preset = 1;
    m.u.animate.speed = 2.5;
    app_rec_put_input(&f->b, 4, &m, &f->p);
    proto_type bare[] = { PROTO_PAUSE, PROTO_RESET, PROTO_RESUME };
    for (int i = 0; i < 3; i++) {
        memset(&m, 0, sizeof m);
        m.type = bare[i];
        app_rec_put_input(&f->b, 10, &m, &f->p);
    }
    memset(&m, 0, sizeof m);
    m.type = PROTO_STEP;
    m.u.step.count = 17;
    app_rec_put_input(&f->b, 10, &m, &f->p);
    memset(&m, 0, sizeof m);
    m.type = PROTO_SET_GROOM;
    m.u.set_groom.style = 2;
    m.u.set_groom.strands = 300;
    m.u.set_groom.has_seed = true;
    m.u.set_groom.seed = 99;
    m.u.set_groom.collider_mode = PROTO_COLLIDER_NONE;
    app_rec_put_input(&f->b, 20, &m, &f->p);
    app_rec_put_digest(&f->b, 21, 42);
    app_rec_put_end(&f->b, 40);
    assert_false(f->b.oom);
}

static void test_round_trip(void **state)
{
    (void)state;
    fixture f;
    setup_parser(&f);
    write_file(&f);
    app_rec_start s;
    app_rec *v;
    size_t n;
    core_err err;
    assert_int_equal(app_rec_read(f.b.p, f.b.len, &f.p, &s, &v, &n, &err), CORE_OK);
    assert_string_equal(s.groom, "wavy");
    assert_int_equal(s.strands, 64);
    assert_int_equal(s.verts, 12);
    assert_true(s.seed == 1234567890123ull);
    assert_int_equal(s.threads, 2);
    assert_memory_equal(&s.params, &f.start.params, sizeof s.params);
    assert_int_equal(n, 11);
    assert_int_equal(v[0].msg.type, PROTO_SET_PARAMS);
    assert_int_equal(v[0].step, 3);
    assert_int_equal(v[0].index, 1);
    assert_true(v[0].msg.u.set_params.v[0].value == 1.0 / 3.0);
    assert_int_equal(v[0].msg.u.set_params.v[1].index, find_index(&f.p, "gravity"));
    assert_int_equal(v[1].msg.type, PROTO_MOTION);
    assert_true(v[1].msg.u.motion.position.z == 1.0f / 3.0f);
    assert_true(v[1].msg.u.motion.orientation.w == 0.9961947f);
    assert_int_equal(v[2].kind, APP_REC_DIGEST);
    assert_true(v[2].digest == 0x0123456789abcdefull);
    assert_int_equal(v[3].msg.type, PROTO_ANIMATE);
    assert_int_equal(v[3].msg.u.animate.preset, 1);
    assert_true(v[3].msg.u.animate.speed == 2.5);
    assert_int_equal(v[4].msg.type, PROTO_PAUSE);
    assert_int_equal(v[5].msg.type, PROTO_RESET);
    assert_int_equal(v[6].msg.type, PROTO_RESUME);
    assert_int_equal(v[7].msg.u.step.count, 17);
    assert_int_equal(v[8].msg.type, PROTO_SET_GROOM);
    assert_int_equal(v[8].msg.u.set_groom.style, 2);
    assert_int_equal(v[8].msg.u.set_groom.strands, 300);
    assert_true(v[8].msg.u.set_groom.has_seed && v[8].msg.u.set_groom.seed == 99);
    assert_int_equal(v[8].msg.u.set_groom.collider_mode, PROTO_COLLIDER_NONE);
    assert_int_equal(v[10].kind, APP_REC_END);
    assert_int_equal(v[10].step, 40);
    free(v);
    app_rec_buf_free(&f.b);
}

/* Reads buf (len bytes) expecting a refusal whose message holds want. */
static void expect_refused(const fixture *f, const uint8_t *buf, size_t len, const char *want)
{
    app_rec_start s;
    app_rec *v;
    size_t n;
    core_err err = { "" };
    assert_int_equal(app_rec_read(buf, len, &f->p, &s, &v, &n, &err), CORE_EFORMAT);
    if (!strstr(err.msg, want)) fail_msg("\"%s\" does not hold \"%s\"", err.msg, want);
    assert_null(v);
}

static void test_refusals(void **state)
{
    (void)state;
    fixture f;
    setup_parser(&f);
    write_file(&f);
    uint8_t *c = malloc(f.b.len + 64);
    memcpy(c, f.b.p, f.b.len);
    c[8] = 7;
    expect_refused(&f, c, f.b.len, "byte 8: field version: format version 7; this strandcastd reads version 1");
    c[8] = 1;
    c[1] = 'X';
    expect_refused(&f, c, f.b.len, "byte 0: field magic");
    c[1] = f.b.p[1];
    expect_refused(&f, c, f.b.len - 3, "field length: truncated");
    /* the end record is 17 bytes: without it the file ends at a record boundary */
    expect_refused(&f, c, f.b.len - 17, "field end: truncated: the recording has no end record");
    /* a byte of the second record's payload: its crc32 no longer matches */
    size_t second = APP_REC_FILE_HEADER + 4 + 13 + (c[APP_REC_FILE_HEADER] | (size_t)c[APP_REC_FILE_HEADER + 1] << 8);
    char want[96];
    snprintf(want, sizeof want, "record 1 at byte %zu: field crc32", second);
    c[second + 20] ^= 0x10;
    expect_refused(&f, c, f.b.len, want);
    c[second + 20] ^= 0x10;
    memcpy(c + f.b.len, c + f.b.len - 17, 17); /* a second end record */
    expect_refused(&f, c, f.b.len + 17, "record 12 at byte");
    expect_refused(&f, c, f.b.len + 17, "records after the end record");
    /* a parameter this build does not have */
    fixture g = f;
    g.p.nparams = find_index(&f.p, "gravity");
    expect_refused(&g, c, f.b.len, "field params: no parameter named \"gravity\" in this build");
    free(c);
    app_rec_buf_free(&f.b);
    /* a value outside its parameter's range */
    f.start.params.gravity = 1e30f;
    write_file(&f);
    expect_refused(&f, f.b.p, f.b.len, "field params: gravity = 1.0000000150474662e+30 is outside [0, 50]");
    app_rec_buf_free(&f.b);
}

static void test_digest_sees_a_bit(void **state)
{
    (void)state;
    float x[300];
    for (int i = 0; i < 300; i++) x[i] = (float)i * 0.01f;
    uint64_t a = app_rec_digest(x, 300);
    uint32_t u;
    memcpy(&u, &x[123], 4);
    u ^= 1;
    memcpy(&x[123], &u, 4);
    assert_true(app_rec_digest(x, 300) != a);
}

/* Writes b to a temporary file; returns its path (static buffer). */
static const char *temp_file(const app_rec_buf *b)
{
    static char path[64];
    snprintf(path, sizeof path, "/tmp/test_app_rec_%d.screc", (int)getpid());
    FILE *fp = fopen(path, "wb");
    assert_non_null(fp);
    assert_int_equal(fwrite(b->p, 1, b->len, fp), b->len);
    fclose(fp);
    return path;
}

static void test_replay_missing_files(void **state)
{
    (void)state;
    fixture f;
    setup_parser(&f);
    app_assets as;
    memset(&as, 0, sizeof as);
    app_replay r;
    core_err err;
    /* a procedural start and a set_groom of a style: no file needed */
    write_file(&f);
    const char *path = temp_file(&f.b);
    assert_int_equal(app_replay_open(&r, path, &f.p, &as, NULL, &err), CORE_OK);
    assert_int_equal(r.end_step, 40);
    assert_non_null(app_replay_input(&r, 3));
    assert_non_null(app_replay_input(&r, 3));
    assert_null(app_replay_input(&r, 3));
    assert_true(app_replay_check(&r, 4, 0x0123456789abcdefull, &err));
    assert_false(app_replay_check(&r, 21, 43, &err)); /* recorded 42 */
    assert_non_null(strstr(err.msg, "the positions after step 21 differ from the recording's (record 10 at byte"));
    app_replay_free(&r);
    app_rec_buf_free(&f.b);
    /* a groom file that is not there */
    snprintf(f.start.groom, sizeof f.start.groom, "/nonexistent/head.hair");
    write_file(&f);
    path = temp_file(&f.b);
    assert_int_equal(app_replay_open(&r, path, &f.p, &as, NULL, &err), CORE_EIO);
    assert_non_null(strstr(err.msg, "record 0 at byte 12: field groom: the groom file /nonexistent/head.hair"));
    app_rec_buf_free(&f.b);
    /* a set_groom of an asset that is not in the folder */
    snprintf(f.start.groom, sizeof f.start.groom, "straight");
    app_rec_put_file_header(&f.b);
    app_rec_put_start(&f.b, &f.start, f.p.params, f.p.nparams);
    size_t at = f.b.len;
    proto_msg m;
    memset(&m, 0, sizeof m);
    m.type = PROTO_SET_GROOM;
    m.u.set_groom.is_file = true;
    snprintf(m.u.set_groom.file, sizeof m.u.set_groom.file, "gone/bob.tfx");
    app_rec_put_input(&f.b, 5, &m, &f.p);
    app_rec_put_end(&f.b, 9);
    path = temp_file(&f.b);
    assert_int_equal(app_replay_open(&r, path, &f.p, &as, "/srv/assets", &err), CORE_EIO);
    char want[128];
    snprintf(want, sizeof want, "record 1 at byte %zu: field file: no groom file \"gone/bob.tfx\" in the asset folder /srv/assets", at);
    if (!strstr(err.msg, want)) fail_msg("\"%s\" does not hold \"%s\"", err.msg, want);
    remove(path);
    app_rec_buf_free(&f.b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_digest_sees_a_bit),
        cmocka_unit_test(test_replay_missing_files),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
