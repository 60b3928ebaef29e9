/* Integration tests: frame streams (slow readers, rate caps, stream slots, encode failures). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#include "it.h"

void test_slow_client_skips(void **state)
{
    fixture *fx = *state;
    view *fast, *slow;
    connect_view(fx, &fast);
    wsc_conn *s = connect_view(fx, &slow);
    wsc_small_rcvbuf(s, 4096);
    wait_frames(fx, slow, 2);
    /* the head moves, so that frames stay large (hair at rest sends nearly empty deltas) */
    wsc_send_text(s, "{\"type\":\"animate\",\"preset\":\"shake\",\"speed\":2}");
    cJSON_Delete(expect_msg(fx, s, "state"));
    /* the slow client stops reading for 2 s while the server keeps streaming */
    wsc_read_enable(s, false);
    uint64_t f0 = fast->ok;
    wsc_run(fx->w, 2000);
    assert_true(fast->ok - f0 >= 20);
    wsc_read_enable(s, true);
    uint64_t s0 = slow->ok;
    wait_frames(fx, slow, s0 + 30);
    assert_int_equal(slow->bad, 0);
    assert_true(wsc_is_open(s));
    http_reply r;
    assert_int_equal(http_get(fx->d.port, "/metrics", &r), 0);
    if (!(metric(r.body, "strandcast_frames_skipped_total") > 0)) fail_msg("no frame was skipped:\n%s", r.body);
    http_reply_free(&r);
}

/* Subscribes c with max_rate and checks the reply's frame rate. */
static void subscribe_rate(fixture *fx, wsc_conn *c, double max_rate, double frame_rate)
{
    char msg[96];
    snprintf(msg, sizeof msg, "{\"type\":\"subscribe\",\"max_rate\":%g}", max_rate);
    wsc_send_text(c, msg);
    cJSON *sub = expect_msg(fx, c, "subscribed");
    const cJSON *so = get(sub, "stream");
    if (num(so, "frame_rate") != frame_rate || num(so, "rate") != 60 || num(so, "max_rate") != max_rate)
        fail_msg("max_rate %g: frame_rate %g, rate %g (want %g, 60)", max_rate, num(so, "frame_rate"), num(so, "rate"),
                 frame_rate);
    cJSON_Delete(sub);
}

/* A client capped below the publishing rate gets a stream of its own rate: every k-th round's
 * frame, with keyframes every keyframe_interval of its own frames (not the full-rate stream's
 * frames thinned, which would send it every keyframe of the full stream). */
void test_rate_streams(void **state)
{
    fixture *fx = *state;
    view *full, *half, *capped;
    wsc_conn *cf = connect_view(fx, &full), *ch = connect_view(fx, &half), *cc = connect_view(fx, &capped);
    wait_frames(fx, half, 1);
    wait_frames(fx, capped, 1);
    subscribe_rate(fx, ch, 30, 30);
    subscribe_rate(fx, cc, 25, 30); /* no divisor rate of 60 is 25: the 30 Hz stream, capped */
    /* frames from here on are of the new streams (each starts with its keyframe) */
    wsc_run(fx->w, 100);
    view *vs[] = { full, half, capped };
    for (int i = 0; i < 3; i++) {
        vs[i]->ok = vs[i]->keys = 0;
        vs[i]->seq_gcd = vs[i]->key_gcd = 0;
    }
    reach_arg k = { &half->keys, 4 };
    if (!wsc_until(fx->w, counted, &k, 3 * WAIT_MS)) fail_msg("%llu keyframes on the 30 Hz stream", (unsigned long long)half->keys);
    unsigned long long t0 = core_now_ns();
    uint64_t c0 = capped->ok;
    wsc_run(fx->w, 2000);
    double secs = (double)(core_now_ns() - t0) / 1e9;
    /* seq counts publishing rounds: the full stream takes each (keyframe every 30), the 30 Hz
     * streams every second one (keyframe every 30 of theirs = 60 rounds) */
    if (full->seq_gcd != 1 || full->key_gcd != 30)
        fail_msg("full stream: seq steps gcd %llu, keyframe steps gcd %llu (want 1, 30)",
                 (unsigned long long)full->seq_gcd, (unsigned long long)full->key_gcd);
    if (half->seq_gcd != 2 || half->key_gcd != 60)
        fail_msg("30 Hz stream: seq steps gcd %llu, keyframe steps gcd %llu (want 2, 60)",
                 (unsigned long long)half->seq_gcd, (unsigned long long)half->key_gcd);
    if (capped->seq_gcd % 2 != 0 || capped->key_gcd % 60 != 0)
        fail_msg("25 Hz cap: seq steps gcd %llu, keyframe steps gcd %llu (want multiples of 2, 60)",
                 (unsigned long long)capped->seq_gcd, (unsigned long long)capped->key_gcd);
    double rate = (double)(capped->ok - c0) / secs;
    if (rate > 25.0 * 1.1) fail_msg("%.1f frames/s at max_rate 25", rate);
    assert_int_equal(full->bad + half->bad + capped->bad, 0);
    assert_true(wsc_is_open(cf) && wsc_is_open(ch) && wsc_is_open(cc));
}

/* Stream slots: with 31 of the 32 taken by other strides and the default stream gone, the last
 * is kept for the default stream, so a newcomer still gets frames; a subscribe no slot can
 * serve is refused (busy) and the client keeps its stream; one with a faster stream of its
 * stride and error shares it. */
void test_stream_slots(void **state)
{
    fixture *fx = *state;
    wsc_conn *others[31];
    for (int i = 0; i < 31; i++) {
        others[i] = wsc_connect(fx->w, fx->d.port, SUBPROTOCOL, NULL, NULL);
        assert_true(wsc_wait_open(fx->w, others[i], WAIT_MS));
        cJSON_Delete(expect_msg(fx, others[i], "hello"));
        char msg[64];
        snprintf(msg, sizeof msg, "{\"type\":\"subscribe\",\"stride\":%d}", i + 2);
        wsc_send_text(others[i], msg);
        cJSON *sub = expect_msg(fx, others[i], "subscribed");
        assert_true(num(get(sub, "stream"), "stride") == i + 2);
        cJSON_Delete(sub);
    }
    /* 31 streams, no default one: the free slot is not for stride 40 */
    wsc_send_text(others[0], "{\"type\":\"subscribe\",\"stride\":40,\"id\":1}");
    cJSON *busy = expect_msg(fx, others[0], "error");
    assert_string_equal(str(busy, "code"), "busy");
    assert_true(num(busy, "id") == 1);
    cJSON_Delete(busy);
    /* a newcomer starts on the default stream, in the kept slot */
    view *v;
    wsc_conn *c = connect_view(fx, &v);
    wait_frames(fx, v, 3);
    assert_int_equal(v->info.nstrands_sent, NSTRANDS);
    /* every slot taken now: refused, and the stream goes on */
    wsc_send_text(c, "{\"type\":\"subscribe\",\"stride\":40,\"id\":2}");
    busy = expect_msg(fx, c, "error");
    assert_string_equal(str(busy, "code"), "busy");
    cJSON_Delete(busy);
    uint64_t n = v->ok;
    wait_frames(fx, v, n + 3);
    assert_int_equal(v->info.nstrands_sent, NSTRANDS);
    /* 10 Hz of stride 2 has no slot of its own: it shares the 60 Hz stride-2 stream, capped */
    wsc_send_text(c, "{\"type\":\"subscribe\",\"stride\":2,\"max_rate\":10,\"id\":3}");
    cJSON *sub = expect_msg(fx, c, "subscribed");
    const cJSON *so = get(sub, "stream");
    assert_true(num(so, "stride") == 2 && num(so, "max_rate") == 10 && num(so, "frame_rate") == 60);
    cJSON_Delete(sub);
    n = v->ok;
    wait_frames(fx, v, n + 3);
    assert_int_equal(v->info.nstrands_sent, NSTRANDS / 2);
    assert_int_equal(v->bad, 0);
}

/* A strand groom has no hair mesh: hello says so (groom.hairmesh null), subscribing to the hair
 * mesh is refused (bad_state, field source) and changes nothing, and the strands go on; the
 * strands source is accepted. */
void test_hairmesh_source_refused(void **state)
{
    fixture *fx = *state;
    view *v;
    wsc_conn *c = connect_view(fx, &v);
    cJSON *hello = expect_msg(fx, c, "hello");
    assert_true(cJSON_IsNull(get(get(hello, "groom"), "hairmesh")));
    assert_string_equal(str(get(hello, "stream"), "codec"), "strand");
    cJSON_Delete(hello);
    wait_frames(fx, v, 3);
    wsc_send_text(c, "{\"type\":\"subscribe\",\"source\":\"hairmesh\",\"max_rate\":10,\"id\":1}");
    cJSON *e = expect_msg(fx, c, "error");
    assert_string_equal(str(e, "code"), "bad_state");
    assert_string_equal(str(e, "field"), "source");
    assert_non_null(strstr(str(e, "message"), "groom.hairmesh is null"));
    assert_true(num(e, "id") == 1);
    cJSON_Delete(e);
    uint64_t n = v->ok;
    wait_frames(fx, v, n + 6); /* the 60 Hz strand stream, unchanged by the refused subscribe */
    assert_int_equal(v->info.nstrands_sent, NSTRANDS);
    assert_int_equal(v->info.codec_id, CODEC_ID_STRAND);
    wsc_send_text(c, "{\"type\":\"subscribe\",\"source\":\"strands\",\"stride\":2,\"id\":2}");
    cJSON *sub = expect_msg(fx, c, "subscribed");
    assert_string_equal(str(get(sub, "stream"), "codec"), "strand");
    assert_true(num(get(sub, "stream"), "stride") == 2);
    cJSON_Delete(sub);
    assert_int_equal(v->bad, 0);
}

int setup_hairmesh(void **state)
{
    static const char *const extra[] = { "--groom", "hairmesh:wavy", "--strands", "256", "--verts", "12", "--solver",
                                         "hairmesh", NULL };
    return setup_with(state, extra);
}

/* The hair mesh as a stream: hello describes it, its topology binary is served and reads back
 * with the hello's counts, subscribe source hairmesh gives hair mesh frames of every column and
 * layer (within the bound of the rest mesh at rest), and a change to a strand solver moves the
 * client back to the strands with an unsolicited subscribed, after which the mesh is refused. */
void test_hairmesh_stream(void **state)
{
    fixture *fx = *state;
    view *v;
    wsc_conn *c = connect_view(fx, &v);
    cJSON *hello = expect_msg(fx, c, "hello");
    const cJSON *hm = get(get(hello, "groom"), "hairmesh");
    const uint32_t ncols = (uint32_t)num(hm, "ncols"), nlayers = (uint32_t)num(hm, "nlayers");
    const uint32_t nstrands = (uint32_t)num(get(hello, "groom"), "strands");
    assert_true(ncols >= 3 && nlayers >= 2 && num(hm, "nguides") == num(get(hello, "groom"), "strands"));
    http_reply r;
    assert_int_equal(http_get(fx->d.port, str(hm, "url"), &r), 0);
    assert_int_equal(r.status, 200);
    assert_true(r.body_len == (size_t)num(hm, "bytes"));
    proto_hairmesh_counts counts;
    core_err err;
    if (proto_hairmesh_bin_read((const unsigned char *)r.body, r.body_len, &counts, &err) != CORE_OK) fail_msg("%s", err.msg);
    assert_true(counts.ncols == ncols && counts.nlayers == nlayers && counts.nfaces == num(hm, "nfaces"));
    char etag[17];
    proto_bin_etag((const unsigned char *)r.body, r.body_len, etag);
    assert_string_equal(etag, str(hm, "etag"));
    http_reply_free(&r);
    cJSON_Delete(hello);
    wait_frames(fx, v, 3);
    assert_int_equal(v->info.codec_id, CODEC_ID_STRAND);

    wsc_send_text(c, "{\"type\":\"subscribe\",\"source\":\"hairmesh\",\"id\":1}");
    cJSON *sub = expect_msg(fx, c, "subscribed");
    const cJSON *so = get(sub, "stream");
    assert_string_equal(str(so, "codec"), "hairmesh");
    assert_true(num(so, "stride") == 1 && num(so, "strands") == ncols && num(sub, "id") == 1);
    cJSON_Delete(sub);
    count_arg shape = { v, ncols, nlayers };
    assert_true(wsc_until(fx->w, frame_shape, &shape, WAIT_MS));
    uint64_t n = v->ok;
    wait_frames(fx, v, n + 5);
    assert_int_equal(v->info.codec_id, CODEC_ID_HAIRMESH);
    assert_true(v->info.stride == 1 && v->info.nstrands_total == ncols);
    assert_true(v->info.frame_len < 16u * ncols * nlayers); /* far below the 12 bytes of raw float32 xyz */

    /* a strand solver: back to the strands, told without an id */
    wsc_send_text(c, "{\"type\":\"set_params\",\"values\":{\"solver\":\"dftl\"},\"id\":2}");
    cJSON *moved = expect_msg(fx, c, "subscribed");
    assert_null(cJSON_GetObjectItemCaseSensitive(moved, "id"));
    assert_string_equal(str(get(moved, "stream"), "codec"), "strand");
    cJSON_Delete(moved);
    count_arg strands = { v, nstrands, 12 };
    assert_true(wsc_until(fx->w, frame_shape, &strands, WAIT_MS));
    assert_int_equal(v->info.codec_id, CODEC_ID_STRAND);
    wsc_send_text(c, "{\"type\":\"subscribe\",\"source\":\"hairmesh\",\"id\":3}");
    cJSON *e = expect_msg(fx, c, "error");
    assert_string_equal(str(e, "code"), "bad_state");
    assert_non_null(strstr(str(e, "message"), "needs the hairmesh solver"));
    cJSON_Delete(e);
    assert_int_equal(v->bad, 0);
}

/* A groom 2 km up cannot be streamed at 0.01 mm (its lattice coordinates would pass 2^26): that
 * stream's clients are told why, and a 1 mm stream goes on. */
void test_stream_failure_is_reported(void **state)
{
    fixture *fx = *state;
    view *v1, *v2;
    wsc_conn *c1 = connect_view(fx, &v1), *c2 = connect_view(fx, &v2);
    cJSON_Delete(expect_msg(fx, c1, "hello"));
    cJSON_Delete(expect_msg(fx, c2, "hello"));
    wsc_send_text(c1, "{\"type\":\"subscribe\",\"max_error\":1e-3}");
    cJSON_Delete(expect_msg(fx, c1, "subscribed"));
    wsc_send_text(c2, "{\"type\":\"subscribe\",\"max_error\":1e-5}");
    cJSON_Delete(expect_msg(fx, c2, "subscribed"));
    wsc_send_text(c1, "{\"type\":\"set_groom\",\"file\":\"far.hair\"}");
    cJSON_Delete(expect_msg(fx, c2, "groom"));
    cJSON *e = expect_msg(fx, c2, "error");
    assert_string_equal(str(e, "code"), "failed");
    assert_string_equal(str(e, "field"), "stream");
    assert_null(cJSON_GetObjectItemCaseSensitive(e, "id"));
    if (!strstr(str(e, "message"), "max_error")) fail_msg("message: %s", str(e, "message"));
    cJSON_Delete(e);
    count_arg far = { v1, 16, 8 };
    assert_true(wsc_until(fx->w, frame_shape, &far, WAIT_MS));
    uint64_t n = v1->ok;
    wait_frames(fx, v1, n + 5);
    assert_true(v1->info.nstrands_total == 16 && fabs(mean_tip_y(v1) - 1999.9) < 1.0);
    /* a client joining the failing stream (c2 still on it) is told at once */
    view *v3;
    wsc_conn *c3 = connect_view(fx, &v3);
    cJSON_Delete(expect_msg(fx, c3, "hello"));
    wsc_send_text(c3, "{\"type\":\"subscribe\",\"max_error\":1e-5,\"id\":7}");
    cJSON_Delete(expect_msg(fx, c3, "subscribed"));
    e = expect_msg(fx, c3, "error");
    assert_string_equal(str(e, "field"), "stream");
    cJSON_Delete(e);
    /* a coarser bound streams again; a groom the fine stream can carry brings its frames back */
    wsc_send_text(c2, "{\"type\":\"subscribe\",\"max_error\":1e-3}");
    cJSON_Delete(expect_msg(fx, c2, "subscribed"));
    assert_true(wsc_until(fx->w, frame_shape, &(count_arg){ v2, 16, 8 }, WAIT_MS));
    uint64_t before = v3->ok;
    wsc_send_text(c1, "{\"type\":\"set_groom\",\"file\":\"tiny.hair\"}");
    cJSON_Delete(expect_msg(fx, c3, "groom"));
    wait_frames(fx, v3, before + 3);
    assert_true(fabs(v3->info.max_error_m - 1e-5) < 1e-9 && fabs(mean_tip_y(v3)) < 1.0);
    assert_int_equal(v1->bad + v2->bad + v3->bad, 0);
}

/* --listen ::1: the daemon serves the IPv6 loopback only (the URL it prints is [::1]:port). */

/* A groom change does not stall the streams: the groom, its simulation and (with --backend
 * auto) its backend are made off the sim thread, the backend chosen once at start-up, so the
 * frames of the old groom keep coming until the swap and the new groom's follow at once. The
 * longest gap between two frames, across a change to the default 4,096 x 32 groom, stays under
 * 100 ms (the sim thread's own step, encode and send included). */
void test_groom_change_keeps_frames(void **state)
{
    fixture *fx = *state;
    view *v;
    wsc_conn *c = connect_view(fx, &v);
    cJSON_Delete(expect_msg(fx, c, "hello"));
    wait_frames(fx, v, 30);
    v->max_gap_s = 0.0;
    wsc_send_text(c, "{\"type\":\"set_groom\",\"style\":\"curly\",\"strands\":4096,\"verts\":32,\"id\":1}");
    cJSON *ok = expect_msg_within(fx, c, "ok", 4 * WAIT_MS);
    assert_true(num(ok, "id") == 1);
    cJSON_Delete(ok);
    cJSON_Delete(expect_msg(fx, c, "groom"));
    count_arg ca = { v, 4096, 32 };
    assert_true(wsc_until(fx->w, frame_shape, &ca, WAIT_MS));
    wait_frames(fx, v, v->ok + 30);
    printf("longest gap between frames across the groom change: %.1f ms\n", v->max_gap_s * 1e3);
    if (!(v->max_gap_s < 0.1)) fail_msg("frames stopped for %.0f ms during the groom change", v->max_gap_s * 1e3);
}

/* One client's flood cannot hurt another: a burst of set_params (each announced to every
 * client) leaves a client that does not read meanwhile connected, since its queue keeps only
 * the newest params; past its budget the flooder gets rate_limited errors and stays open.
 * The newest params carries every value: a change of another parameter in the middle of the
 * burst (gravity) is not lost when later announcements replace the one that named it. */
void test_flood_spares_others(void **state)
{
    fixture *fx = *state;
    view *va, *vb;
    wsc_conn *a = connect_view(fx, &va), *b = connect_view(fx, &vb);
    cJSON_Delete(expect_msg(fx, a, "hello"));
    cJSON_Delete(expect_msg(fx, b, "hello"));
    wait_frames(fx, vb, 5);
    wsc_small_rcvbuf(b, 4096);
    wsc_read_enable(b, false); /* b's socket backs up: what the server sends it waits in b's queue */
    /* 2,000 at once: about the first 128 (the burst) are carried out and announced, the rest refused */
    char msg[128];
    for (int i = 0; i < 2000; i++) {
        if (i == 60)
            snprintf(msg, sizeof msg, "{\"type\":\"set_params\",\"values\":{\"gravity\":3.5}}");
        else
            snprintf(msg, sizeof msg, "{\"type\":\"set_params\",\"values\":{\"wind_x\":%d}}", i % 50);
        wsc_send_text(a, msg);
    }
    wsc_send_text(a, "{\"type\":\"get_params\",\"id\":\"last\"}");
    cJSON *e = expect_msg(fx, a, "error");
    assert_string_equal(str(e, "code"), "rate_limited");
    cJSON_Delete(e);
    /* b was not read during the flood: still open, frames still coming, the newest params there */
    wsc_read_enable(b, true);
    uint64_t before = vb->ok;
    wait_frames(fx, vb, before + 10);
    assert_true(wsc_is_open(b));
    assert_true(wsc_is_open(a));
    cJSON *p = expect_msg(fx, b, "params");
    for (const char *t; (t = wsc_next_of_type(fx->w, b, "params", 300)) != NULL;) { /* the newest */
        cJSON_Delete(p);
        p = cJSON_Parse(t);
    }
    assert_true(num(get(p, "values"), "gravity") == 3.5);
    cJSON_Delete(p);
    http_reply r;
    assert_int_equal(http_get(fx->d.port, "/metrics", &r), 0);
    double coalesced = metric(r.body, "strandcast_text_coalesced_total");
    double rejected = metric(r.body, "strandcast_control_messages_total{result=\"rejected\"}");
    http_reply_free(&r);
    printf("coalesced %.0f announcements, %.0f messages rejected\n", coalesced, rejected);
    assert_true(coalesced > 100);
    assert_true(rejected >= 1000);
    /* after a second the budget is back: requests are carried out again */
    double t = now_s() + 1.0;
    while (now_s() < t) wsc_run(fx->w, 50);
    wsc_send_text(a, "{\"type\":\"get_params\",\"id\":\"again\"}");
    for (;;) {
        cJSON *m = expect_msg_within(fx, a, "params", WAIT_MS);
        const cJSON *id = cJSON_GetObjectItemCaseSensitive(m, "id");
        bool mine = cJSON_IsString(id) && strcmp(id->valuestring, "again") == 0;
        cJSON_Delete(m);
        if (mine) break;
    }
}
