/* Integration tests: access control (the token and read-only clients, browser origins) and TLS. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "it.h"

/* A fresh folder for files the daemon reads at start-up; removed by teardown. */
static void make_files_dir(char *dir, size_t cap)
{
    snprintf(dir, cap, "/tmp/strandcast-files-XXXXXX");
    assert_non_null(mkdtemp(dir));
}

/* setup_with plus the files folder recorded in the fixture for teardown. */
static int setup_keeping(void **state, const char *const *extra, const char *dir)
{
    int rc = setup_with(state, extra);
    fixture *fx = *state;
    snprintf(fx->files, sizeof fx->files, "%s", dir);
    return rc;
}

int setup_token(void **state)
{
    char dir[64], path[96];
    make_files_dir(dir, sizeof dir);
    snprintf(path, sizeof path, "%s/token", dir);
    write_file(path, IT_TOKEN "\n", strlen(IT_TOKEN) + 1);
    chmod(path, 0600);
    const char *extra[] = { "--token-file", path, NULL };
    return setup_keeping(state, extra, dir);
}

int setup_origin(void **state)
{
    static const char *const extra[] = { "--allow-origin", "https://good.example", NULL };
    return setup_with(state, extra);
}

int setup_tls(void **state)
{
    char dir[64], cmd[512], cert[96], key[96];
    make_files_dir(dir, sizeof dir);
    snprintf(cert, sizeof cert, "%s/cert.pem", dir);
    snprintf(key, sizeof key, "%s/key.pem", dir);
    snprintf(cmd, sizeof cmd,
             "openssl req -x509 -newkey rsa:2048 -nodes -keyout %s -out %s -days 1 -subj /CN=localhost 2>/dev/null", key,
             cert);
    assert_int_equal(system(cmd), 0);
    const char *extra[] = { "--tls-cert", cert, "--tls-key", key, NULL };
    return setup_keeping(state, extra, dir);
}

/* The error reply of type code to the request with id (a number). */
static void expect_error(fixture *fx, wsc_conn *c, double id, const char *code, const char *field)
{
    cJSON *e = expect_msg(fx, c, "error");
    assert_true(num(e, "id") == id);
    assert_string_equal(str(e, "code"), code);
    assert_string_equal(str(e, "field"), field);
    cJSON_Delete(e);
}

/* With --token-file a client is read-only (hello, frames, subscribe) until it sends the token:
 * a wrong one is refused, the right one makes it a writer; other clients stay read-only. */
void test_token_makes_writers(void **state)
{
    fixture *fx = *state;
    view *v1, *v2;
    wsc_conn *c1 = connect_view(fx, &v1);
    cJSON *h = expect_msg(fx, c1, "hello");
    assert_string_equal(str(h, "access"), "token");
    cJSON_Delete(h);
    wait_frames(fx, v1, 2);
    wsc_send_text(c1, "{\"type\":\"set_params\",\"id\":1,\"values\":{\"gravity\":3}}");
    expect_error(fx, c1, 1, "forbidden", "");
    wsc_send_text(c1, "{\"type\":\"subscribe\",\"id\":2,\"stride\":2}");
    cJSON *sub = expect_msg(fx, c1, "subscribed");
    assert_true(num(sub, "id") == 2);
    cJSON_Delete(sub);
    wsc_send_text(c1, "{\"type\":\"auth\",\"id\":3,\"token\":\"" IT_TOKEN "x\"}");
    expect_error(fx, c1, 3, "forbidden", "token");
    wsc_send_text(c1, "{\"type\":\"auth\",\"id\":4,\"token\":\"" IT_TOKEN "\"}");
    cJSON *ok = expect_msg(fx, c1, "ok");
    assert_true(num(ok, "id") == 4);
    assert_string_equal(str(ok, "request"), "auth");
    cJSON_Delete(ok);
    wsc_send_text(c1, "{\"type\":\"set_params\",\"id\":5,\"values\":{\"gravity\":3}}");
    ok = expect_msg(fx, c1, "ok");
    assert_true(num(ok, "id") == 5);
    cJSON_Delete(ok);
    wsc_conn *c2 = connect_view(fx, &v2);
    cJSON_Delete(expect_msg(fx, c2, "hello"));
    wsc_send_text(c2, "{\"type\":\"reset\",\"id\":6}");
    expect_error(fx, c2, 6, "forbidden", "");
    wait_frames(fx, v2, 3); /* read-only clients get the frames */
}

/* --allow-origin: a browser from another origin is refused with 403 and the reason; the listed
 * origin, and a client that sends no Origin, get in. */
void test_origin_refused(void **state)
{
    fixture *fx = *state;
    static const char *const req =
        "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
        "Sec-WebSocket-Protocol: " SUBPROTOCOL "\r\n%s\r\n";
    char buf[512];
    snprintf(buf, sizeof buf, req, "Origin: https://evil.example\r\n");
    expect_http(fx, buf, 403, "https://evil.example", 3000);
    snprintf(buf, sizeof buf, req, "Origin: https://good.example\r\n");
    expect_http(fx, buf, 101, NULL, 300);
    snprintf(buf, sizeof buf, req, "");
    expect_http(fx, buf, 101, NULL, 300);
}

/* --tls-cert/--tls-key: the daemon speaks wss (hello and decodable frames over TLS); a plain
 * WebSocket client does not get in. */
void test_tls_serves_wss(void **state)
{
    fixture *fx = *state;
    view *v;
    wsc_conn *c = connect_view_via(fx, true, &v);
    cJSON_Delete(expect_msg(fx, c, "hello"));
    wait_frames(fx, v, 3);
    assert_int_equal(v->bad, 0);
    /* wsc_http_get over TLS: the groom data binary from the same port */
    wsc_http_reply r;
    wsc_http_desc d = { .port = fx->d.port, .tls = true, .path = "/groom.bin" };
    if (!wsc_http_get(fx->w, &d, &r)) fail_msg("GET https /groom.bin: %s", r.error);
    assert_int_equal(r.status, 200);
    uint32_t ns, nv;
    core_err err;
    if (proto_groom_bin_read(r.body, r.len, &ns, &nv, &err) != CORE_OK) fail_msg("%s", err.msg);
    assert_int_equal(ns, NSTRANDS);
    wsc_http_reply_free(&r);
    wsc_conn *plain = wsc_connect(fx->w, fx->d.port, SUBPROTOCOL, NULL, NULL);
    assert_false(wsc_wait_open(fx->w, plain, 3000));
}
