/* Integration scenarios of the WebSocket client library's HTTP GET (wsc_http_get): the groom
 * data binary as the hello announces it, a missing path, a body over the cap, a port nobody
 * listens on; the WebSocket connections of the same wsc keep being served meanwhile. */
#include <string.h>

#include "it.h"

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
