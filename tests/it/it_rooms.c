/* Integration tests: rooms (the WebSocket path names the room; one daemon serves one). */
#include <stdio.h>
#include <string.h>

#include "it.h"

int setup_room(void **state)
{
    static const char *const extra[] = { "--room", "studio-2", NULL };
    return setup_with(state, extra);
}

/* A connection to path: its error (code, field "room") and then its close (close code). */
static void expect_refused(fixture *fx, const char *path, const char *code, int close_code)
{
    wsc_conn *c = wsc_connect_path(fx->w, fx->d.port, path, SUBPROTOCOL, NULL, NULL);
    cJSON *e = expect_msg(fx, c, "error");
    assert_string_equal(str(e, "code"), code);
    assert_string_equal(str(e, "field"), "room");
    assert_null(cJSON_GetObjectItemCaseSensitive(e, "id"));
    cJSON_Delete(e);
    assert_int_equal(wsc_wait_closed(fx->w, c, WAIT_MS), close_code);
    assert_null(wsc_next_of_type(fx->w, c, "hello", 0)); /* no hello before the error */
}

void test_rooms_one_per_daemon(void **state)
{
    fixture *fx = *state;
    /* the room it serves: hello names it, frames flow */
    view *v = &fx->views[fx->nviews++];
    codec_decoder_init(&v->dec);
    wsc_conn *c = wsc_connect_path(fx->w, fx->d.port, "/rooms/studio-2", SUBPROTOCOL, on_frame, v);
    cJSON *h = expect_msg(fx, c, "hello");
    assert_string_equal(str(h, "room"), "studio-2");
    cJSON_Delete(h);
    wait_frames(fx, v, 3);
    /* another room, the default one, and names that are no room names */
    expect_refused(fx, "/rooms/other", "unknown_room", PROTO_CLOSE_UNKNOWN_ROOM);
    expect_refused(fx, "/", "unknown_room", PROTO_CLOSE_UNKNOWN_ROOM);
    expect_refused(fx, "/rooms/", "bad_room", PROTO_CLOSE_BAD_ROOM);
    expect_refused(fx, "/rooms/a.b", "bad_room", PROTO_CLOSE_BAD_ROOM);
    expect_refused(fx, "/rooms/studio-2/x", "bad_room", PROTO_CLOSE_BAD_ROOM);
    char longname[160];
    snprintf(longname, sizeof longname, "/rooms/%065d", 7);
    expect_refused(fx, longname, "bad_room", PROTO_CLOSE_BAD_ROOM);
    /* the refusals left the room's client streaming */
    uint64_t before = v->ok;
    wait_frames(fx, v, before + 3);
    assert_true(wsc_is_open(c));
    /* the page at /rooms/NAME is the viewer's index.html */
    expect_http(fx, "GET /rooms/studio-2 HTTP/1.1\r\nHost: x\r\n\r\n", 200, "<title>t</title>", 3000);
    /* and its binaries under its path, the same as at / */
    http_reply a, b;
    assert_int_equal(http_get(fx->d.port, "/groom.bin", &a), 0);
    assert_int_equal(http_get(fx->d.port, "/rooms/studio-2/groom.bin", &b), 0);
    assert_int_equal(b.status, 200);
    assert_true(a.body_len == b.body_len && a.body_len > 0 && memcmp(a.body, b.body, a.body_len) == 0);
    http_reply_free(&a);
    http_reply_free(&b);
}

void test_rooms_default(void **state)
{
    fixture *fx = *state;
    wsc_conn *c = wsc_connect_path(fx->w, fx->d.port, "/rooms/default", SUBPROTOCOL, NULL, NULL);
    cJSON *h = expect_msg(fx, c, "hello");
    assert_string_equal(str(h, "room"), PROTO_DEFAULT_ROOM);
    cJSON_Delete(h);
    c = wsc_connect(fx->w, fx->d.port, SUBPROTOCOL, NULL, NULL);
    h = expect_msg(fx, c, "hello");
    assert_string_equal(str(h, "room"), PROTO_DEFAULT_ROOM);
    cJSON_Delete(h);
    expect_refused(fx, "/rooms/studio-2", "unknown_room", PROTO_CLOSE_UNKNOWN_ROOM);
}
