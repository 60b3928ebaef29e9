/* Integration tests: a character collision mesh (Ratboy from the shared assets; skipped when they are absent). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "it.h"

/* ---- the collision mesh (Ratboy, from the shared assets; skipped when they are absent) ---- */

#define RATBOY_VERTS 12909u
#define RATBOY_TRIS 25814u
#define MESH_WAIT_MS 240000 /* the SDF of the Ratboy body takes seconds (minutes under ASan) */

/* The shared asset folder (STRANDCAST_ASSETS, else next to the source tree), or NULL when the
 * Ratboy files are not there. */
static const char *ratboy_assets(void)
{
    static char dir[1024];
    const char *env = getenv("STRANDCAST_ASSETS");
    snprintf(dir, sizeof dir, "%s", env ? env : STRANDCAST_SOURCE_DIR "/../shared/assets");
    char p[1100];
    snprintf(p, sizeof p, "%s/ratboy/Ratboy_body.tfxmesh", dir);
    if (access(p, R_OK) != 0) return NULL;
    snprintf(p, sizeof p, "%s/ratboy/Ratboy_mohawk.tfx", dir);
    return access(p, R_OK) == 0 ? dir : NULL;
}

/* The daemon with --groom Ratboy_mohawk.tfx --collider Ratboy_body.tfxmesh and an asset folder
 * holding links to both, a malformed mesh and a tiny .hair. Leaves *state NULL (the test then
 * skips) when the assets are absent. */
int setup_ratboy(void **state)
{
    const char *src = ratboy_assets();
    if (!src) {
        *state = NULL;
        return 0;
    }
    fixture *fx = calloc(1, sizeof *fx);
    fx->cfg = *state;
    snprintf(fx->dir, sizeof fx->dir, "/tmp/strandcast-it-XXXXXX");
    assert_non_null(mkdtemp(fx->dir));
    snprintf(fx->assets, sizeof fx->assets, "%s/assets", fx->dir);
    mkdir(fx->assets, 0755);
    char p[1200], q[1200], groom[1200], mesh[1200];
    snprintf(p, sizeof p, "%s/ratboy", fx->assets);
    mkdir(p, 0755);
    static const char *const names[] = { "Ratboy_mohawk.tfx", "Ratboy_body.tfxmesh" };
    for (int i = 0; i < 2; i++) {
        snprintf(p, sizeof p, "%s/ratboy/%s", src, names[i]);
        snprintf(q, sizeof q, "%s/ratboy/%s", fx->assets, names[i]);
        assert_int_equal(symlink(p, q), 0);
    }
    snprintf(groom, sizeof groom, "%s/ratboy/Ratboy_mohawk.tfx", src);
    snprintf(mesh, sizeof mesh, "%s/ratboy/Ratboy_body.tfxmesh", src);
    snprintf(p, sizeof p, "%s/bad.obj", fx->assets); /* an open mesh: one triangle */
    write_file(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 32);
    snprintf(p, sizeof p, "%s/tiny.hair", fx->assets);
    write_hair(p, 16, 8, 0.0f);
    char *argv[] = { (char *)fx->cfg->exe, "--port", "0", "--backend", "cpu", "--threads", "1", "--verts", "8", "--min-step-rate", "0",
                     "--assets", fx->assets, "--groom", groom, "--collider", mesh, NULL };
    assert_int_equal(daemon_start(&fx->d, fx->cfg->exe, argv, MESH_WAIT_MS), 0);
    fx->w = wsc_new();
    assert_non_null(fx->w);
    *state = fx;
    return 0;
}

int teardown_ratboy(void **state) { return *state ? teardown(state) : 0; }

/* GET path; checks the reply is the documented mesh binary of the hello's description. */
static void check_mesh_bin(fixture *fx, const cJSON *desc)
{
    http_reply r;
    assert_int_equal(http_get(fx->d.port, str(desc, "url"), &r), 0);
    if (r.status != 200) fail_msg("GET %s: %d\n%.300s", str(desc, "url"), r.status, r.raw);
    assert_string_equal(r.content_type, "application/octet-stream");
    assert_true(r.body_len == (size_t)num(desc, "bytes"));
    uint32_t nv, nt;
    core_err err;
    if (proto_mesh_bin_read((const unsigned char *)r.body, r.body_len, &nv, &nt, &err) != CORE_OK) fail_msg("%s", err.msg);
    assert_int_equal(nv, RATBOY_VERTS);
    assert_int_equal(nt, RATBOY_TRIS);
    /* positions inside the described bounds; the tag is the bytes' hash, also the ETag */
    const cJSON *b = get(desc, "bounds");
    for (uint32_t i = 0; i < 3 * nv; i++) {
        float f;
        memcpy(&f, r.body + PROTO_MESH_HEADER + 4 * i, 4);
        double lo = cJSON_GetArrayItem(b, (int)(i % 3))->valuedouble, hi = cJSON_GetArrayItem(b, (int)(i % 3) + 3)->valuedouble;
        if (!(f >= lo - 1e-6 && f <= hi + 1e-6)) fail_msg("vertex %u coordinate %g outside [%g, %g]", i / 3, (double)f, lo, hi);
    }
    char etag[17], hdr[32];
    proto_bin_etag((const unsigned char *)r.body, r.body_len, etag);
    assert_string_equal(etag, str(desc, "etag"));
    snprintf(hdr, sizeof hdr, "\"%s\"", etag);
    if (!strstr(r.raw, hdr)) fail_msg("no ETag %s in:\n%.300s", hdr, r.raw);
    http_reply_free(&r);
    /* revalidation: the same tag answers 304 without a body */
    char req[256];
    snprintf(req, sizeof req, "GET %s HTTP/1.1\r\nHost: 127.0.0.1\r\nIf-None-Match: %s\r\nConnection: close\r\n\r\n",
             str(desc, "url"), hdr);
    assert_int_equal(http_exchange(fx->d.port, req, &r, 5000), 0);
    assert_int_equal(r.status, 304);
    assert_int_equal(r.body_len, 0);
    http_reply_free(&r);
}

/* One set_groom that must be refused with code on field; the stream goes on. */
static void expect_groom_error(fixture *fx, wsc_conn *c, view *v, const char *msg, const char *code, const char *field)
{
    wsc_send_text(c, msg);
    cJSON *e = expect_msg(fx, c, "error");
    if (strcmp(str(e, "code"), code) != 0 || strcmp(str(e, "field"), field) != 0)
        fail_msg("%s: %s / %s (%s), want %s / %s", msg, str(e, "code"), str(e, "field"), str(e, "message"), code, field);
    cJSON_Delete(e);
    wait_frames(fx, v, v->ok + 3);
}

void test_collider_mesh(void **state)
{
    fixture *fx = *state;
    if (!fx) skip();
    view *v;
    wsc_conn *c = connect_view(fx, &v);
    cJSON *h = expect_msg(fx, c, "hello");
    const cJSON *desc = get(h, "collider_mesh");
    assert_true(num(desc, "verts") == RATBOY_VERTS && num(desc, "triangles") == RATBOY_TRIS);
    assert_string_equal(str(desc, "source"), "Ratboy_body.tfxmesh");
    assert_string_equal(str(desc, "url"), "/collider.bin");
    const cJSON *sdf = get(desc, "sdf");
    assert_true(num(sdf, "cell") >= 0.002 - 1e-9);
    const cJSON *meshes = get(get(h, "grooms"), "colliders");
    assert_int_equal(cJSON_GetArraySize(meshes), 2); /* bad.obj and the body, sorted */
    assert_string_equal(cJSON_GetArrayItem(meshes, 1)->valuestring, "ratboy/Ratboy_body.tfxmesh");
    /* the fitted head ellipsoid stays: the mesh adds to the analytic colliders */
    assert_int_equal(cJSON_GetArraySize(get(h, "colliders")), 1);
    check_mesh_bin(fx, desc);
    wait_frames(fx, v, 3);

    /* refusals: the stream goes on after each */
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":\"nope.obj\",\"id\":1}", "not_found", "collider");
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":\"ratboy/Ratboy_mohawk.tfx\"}", "not_found", "collider");
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":\"../ratboy/Ratboy_body.tfxmesh\"}", "bad_field", "collider");
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":\"/etc/passwd\"}", "bad_field", "collider");
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":\"bad.obj\\u0000x\"}", "bad_field", "collider");
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"style\":\"wavy\",\"collider\":7}", "bad_field", "collider");
    expect_groom_error(fx, c, v, "{\"type\":\"set_groom\",\"file\":\"tiny.hair\",\"collider\":\"bad.obj\"}", "failed", "collider");

    /* none: the groom message says so and the binary is gone */
    wsc_send_text(c, "{\"type\":\"set_groom\",\"file\":\"tiny.hair\",\"collider\":null,\"id\":2}");
    cJSON *g = expect_msg(fx, c, "groom");
    assert_true(cJSON_IsNull(get(g, "collider_mesh")));
    cJSON_Delete(g);
    http_reply r;
    assert_int_equal(http_get(fx->d.port, "/collider.bin", &r), 0);
    assert_int_equal(r.status, 404);
    http_reply_free(&r);

    /* the body again, with a groom file: the loads run beside the simulation, whose frames go on */
    uint64_t before = v->ok;
    unsigned long long t0 = core_now_ns();
    wsc_send_text(c, "{\"type\":\"set_groom\",\"file\":\"ratboy/Ratboy_mohawk.tfx\",\"verts\":8,"
                     "\"collider\":\"ratboy/Ratboy_body.tfxmesh\",\"id\":3}");
    cJSON_Delete(expect_msg_within(fx, c, "ok", MESH_WAIT_MS));
    double secs = (double)(core_now_ns() - t0) / 1e9;
    uint64_t during = v->ok - before;
    fprintf(stderr, "set_groom with the Ratboy body: %.2f s, %llu frames meanwhile\n", secs, (unsigned long long)during);
    if (secs > 1.0 && during < 10) fail_msg("%llu frames in the %.1f s of the load: the simulation stalled", (unsigned long long)during, secs);
    g = expect_msg(fx, c, "groom");
    const cJSON *d2 = get(g, "collider_mesh");
    assert_string_equal(str(d2, "source"), "ratboy/Ratboy_body.tfxmesh");
    assert_string_equal(str(d2, "etag"), str(desc, "etag")); /* the same bytes */
    check_mesh_bin(fx, d2);
    /* absent = keep: a procedural groom keeps the body */
    wsc_send_text(c, "{\"type\":\"set_groom\",\"style\":\"straight\",\"strands\":64,\"verts\":4,\"id\":4}");
    cJSON_Delete(expect_msg_within(fx, c, "ok", MESH_WAIT_MS));
    cJSON *g2 = expect_msg(fx, c, "groom");
    assert_true(num(get(g2, "collider_mesh"), "triangles") == RATBOY_TRIS);
    count_arg ca = { v, 64, 4 };
    assert_true(wsc_until(fx->w, frame_shape, &ca, WAIT_MS));
    assert_int_equal(v->bad, 0);
    cJSON_Delete(g2);
    cJSON_Delete(g);
    cJSON_Delete(h);
}
