/* Integration scenarios of the WebSocket client library's HTTP GET (wsc_http_get): the groom
 * data binary as the hello announces it, a missing path, a body over the cap, a port nobody
 * listens on; the WebSocket connections of the same wsc keep being served meanwhile. */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include "it.h"

#define CHUNKS 4
#define CHUNK 1000

/* A child process that answers `times` GETs on a loopback port (into *port) with a chunked
 * 200 of CHUNKS x CHUNK bytes (no Content-Length: the cap is met while the body arrives), or
 * when stall, reads the first request and answers nothing for 2 s. Returns the child's pid. */
static pid_t serve_chunked(int times, bool stall, int *port)
{
    int ls = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
    socklen_t alen = sizeof a;
    assert_true(ls >= 0 && bind(ls, (struct sockaddr *)&a, sizeof a) == 0 && listen(ls, 4) == 0);
    assert_int_equal(getsockname(ls, (struct sockaddr *)&a, &alen), 0);
    *port = ntohs(a.sin_port);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid > 0) {
        close(ls);
        return pid;
    }
    static char body[CHUNK];
    memset(body, 'x', sizeof body);
    for (int i = 0; i < times; i++) {
        int c = accept(ls, NULL, NULL);
        if (c < 0) _exit(1);
        char req[4096];
        size_t got = 0;
        while (got < sizeof req - 1) { /* the request, to its blank line */
            ssize_t n = read(c, req + got, sizeof req - 1 - got);
            if (n <= 0) break;
            got += (size_t)n;
            req[got] = '\0';
            if (strstr(req, "\r\n\r\n")) break;
        }
        if (stall && i == 0) {
            sleep(2);
            close(c);
            continue;
        }
        const char *head = "HTTP/1.1 200 OK\r\nContent-Type: application/octet-stream\r\nTransfer-Encoding: chunked\r\n"
                           "Connection: close\r\n\r\n";
        ssize_t w = write(c, head, strlen(head));
        for (int k = 0; k < CHUNKS && w > 0; k++) {
            char size[16];
            snprintf(size, sizeof size, "%x\r\n", CHUNK);
            w = write(c, size, strlen(size));
            if (w > 0) w = write(c, body, sizeof body);
            if (w > 0) w = write(c, "\r\n", 2);
        }
        if (w > 0) w = write(c, "0\r\n\r\n", 5);
        close(c);
    }
    _exit(0);
}

/* /groom.bin fetched with wsc_http_get matches the hello's url, etag and bytes and reads with
 * proto_groom_bin_read; a missing path answers 404; a cap below the size fails before the body,
 * naming the limit; a closed port fails, saying it cannot connect. */
void test_wsc_http_get(void **state)
{
    fixture *fx = *state;
    view *v;
    wsc_conn *c = connect_view(fx, &v);
    cJSON *hello = expect_msg(fx, c, "hello");
    const cJSON *g = cJSON_GetObjectItemCaseSensitive(hello, "groom");
    const cJSON *url = cJSON_GetObjectItemCaseSensitive(g, "url"), *etag = cJSON_GetObjectItemCaseSensitive(g, "etag"),
                *bytes = cJSON_GetObjectItemCaseSensitive(g, "bytes");
    assert_true(cJSON_IsString(url) && cJSON_IsString(etag) && cJSON_IsNumber(bytes));
    wait_frames(fx, v, 2);
    uint64_t before = v->ok;
    wsc_http_reply r;
    wsc_http_desc d = { .port = fx->d.port, .path = url->valuestring };
    if (!wsc_http_get(fx->w, &d, &r)) fail_msg("GET %s: %s", url->valuestring, r.error);
    assert_int_equal(r.status, 200);
    assert_int_equal(r.len, (size_t)bytes->valuedouble);
    char tag[17];
    proto_bin_etag(r.body, r.len, tag);
    assert_string_equal(tag, etag->valuestring);
    uint32_t ns, nv;
    core_err err;
    if (proto_groom_bin_read(r.body, r.len, &ns, &nv, &err) != CORE_OK) fail_msg("%s", err.msg);
    assert_int_equal(ns, NSTRANDS);
    assert_int_equal(nv, NVERTS);
    wsc_http_reply_free(&r);
    assert_null(r.body);
    /* the cap exactly at the size is enough; one byte under is not */
    d.max_bytes = (size_t)bytes->valuedouble;
    assert_true(wsc_http_get(fx->w, &d, &r));
    assert_int_equal(r.len, d.max_bytes);
    wsc_http_reply_free(&r);
    d.max_bytes -= 1;
    assert_false(wsc_http_get(fx->w, &d, &r));
    assert_null(r.body);
    if (!strstr(r.error, "exceeds the") || !strstr(r.error, "-byte limit")) fail_msg("over the cap: %s", r.error);
    /* a path the server does not have: a response, 404 */
    wsc_http_desc missing = { .port = fx->d.port, .path = "/no-such-file.bin" };
    if (!wsc_http_get(fx->w, &missing, &r)) fail_msg("GET /no-such-file.bin: %s", r.error);
    assert_int_equal(r.status, 404);
    wsc_http_reply_free(&r);
    /* the WebSocket connection of the same wsc was served meanwhile and still is */
    wait_frames(fx, v, before + 2);
    assert_int_equal(v->bad, 0);
    /* nobody listens on port 1 (privileged, unused on a test machine): cannot connect */
    wsc_http_desc closed = { .port = 1, .path = "/groom.bin", .timeout_ms = 3000 };
    assert_false(wsc_http_get(fx->w, &closed, &r));
    assert_int_equal(r.status, 0);
    if (!strstr(r.error, "connect")) fail_msg("closed port: %s", r.error);
    cJSON_Delete(hello);
}

/* A chunked body (no Content-Length) is taken whole under the cap and refused once it passes
 * it, as it arrives; a server that does not answer meets the timeout, and the wsc still works. */
void test_wsc_http_get_chunked(void **state)
{
    fixture *fx = *state;
    int port;
    pid_t pid = serve_chunked(2, false, &port);
    wsc_http_reply r;
    wsc_http_desc d = { .port = port, .path = "/data", .max_bytes = CHUNKS * CHUNK };
    if (!wsc_http_get(fx->w, &d, &r)) fail_msg("chunked GET: %s", r.error);
    assert_int_equal(r.status, 200);
    assert_int_equal(r.len, CHUNKS * CHUNK);
    assert_true(r.body[0] == 'x' && r.body[r.len - 1] == 'x');
    wsc_http_reply_free(&r);
    d.max_bytes = CHUNKS * CHUNK - 1;
    assert_false(wsc_http_get(fx->w, &d, &r));
    assert_null(r.body);
    assert_string_equal(r.error, "the body exceeds the 3999-byte limit");
    int status;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    assert_true(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    /* a server that never answers: the GET gives up at its timeout, and the next one works */
    pid = serve_chunked(2, true, &port);
    wsc_http_desc slow = { .port = port, .path = "/data", .timeout_ms = 300 };
    unsigned long long t0 = core_now_ns();
    assert_false(wsc_http_get(fx->w, &slow, &r));
    double waited_ms = (double)(core_now_ns() - t0) / 1e6;
    if (!strstr(r.error, "no complete response from 127.0.0.1:") || !strstr(r.error, "/data in 300 ms") || waited_ms > 1800)
        fail_msg("after %.0f ms: %s", waited_ms, r.error);
    slow.timeout_ms = 0;
    if (!wsc_http_get(fx->w, &slow, &r)) fail_msg("after a timeout: %s", r.error);
    assert_int_equal(r.len, CHUNKS * CHUNK);
    wsc_http_reply_free(&r);
    assert_int_equal(waitpid(pid, &status, 0), pid);
}
