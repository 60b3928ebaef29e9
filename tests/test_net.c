/* Tests for server/net's pure parts (subprotocol lists, refcounted buffers);
 * the server itself is exercised end to end by tests/it/. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <arpa/inet.h>
#include <stdio.h>
#include <string.h>

#include "net/net_internal.h"

static void test_token_list(void **state)
{
    (void)state;
    assert_true(net_token_listed("strandcast.v3", "strandcast.v3"));
    assert_true(net_token_listed("chat, strandcast.v3", "strandcast.v3"));
    assert_true(net_token_listed(" strandcast.v3 ,x", "strandcast.v3"));
    assert_true(net_token_listed("a,,strandcast.v3\t", "strandcast.v3"));
    assert_false(net_token_listed("", "strandcast.v3"));
    assert_false(net_token_listed("strandcast.v30", "strandcast.v3"));
    assert_false(net_token_listed("strandcast.v", "strandcast.v3"));
    assert_false(net_token_listed("xstrandcast.v3", "strandcast.v3"));
    assert_false(net_token_listed("strandcast v1", "strandcast.v3"));
}

static void test_buffers(void **state)
{
    (void)state;
    net_buf *b = net_buf_new(5);
    assert_non_null(b);
    memcpy(net_buf_data(b), "hello", 5);
    assert_int_equal(net_buf_len(b), 5);
    net_buf_ref(b);
    net_buf_unref(b);
    assert_memory_equal(net_buf_data(b), "hello", 5); /* still alive: one reference left */
    net_buf_unref(b);
    net_buf_unref(NULL);
    assert_null(net_buf_new(SIZE_MAX - 4));
}

/* The IPv4 address a TCP port listens on, from /proc/net/tcp (host order); 0 when not found. */
static unsigned listen_addr4(int port)
{
    FILE *f = fopen("/proc/net/tcp", "r");
    if (!f) return 0;
    char line[512];
    unsigned found = 0;
    while (fgets(line, sizeof line, f)) {
        unsigned addr, p, st;
        if (sscanf(line, " %*d: %8X:%4X %*8X:%*4X %2X", &addr, &p, &st) == 3 && (int)p == port && st == 0x0A) {
            found = ntohl(addr) == 0 ? 0xffffffffu : ntohl(addr);
            break;
        }
    }
    fclose(f);
    return found; /* 0xffffffff = bound to 0.0.0.0 */
}

static void test_binds_only_the_address(void **state)
{
    (void)state;
    net *n = NULL;
    core_err err;
    net_desc d = { .subprotocol = "strandcast.v3", .port = NET_PORT_ANY };
    assert_int_equal(net_create(&n, &d, &err), CORE_OK); /* default 127.0.0.1 */
    unsigned a = listen_addr4(net_port(n));
    if (a != 0x7f000001u) fail_msg("listening on %08x, want 127.0.0.1 only", a);
    net_destroy(n);
}

/* Frames the net thread has not taken yet are replaced by newer ones (newest wins); those still
 * count as published, so that every client's skipped count includes them. */
static void test_inbox_merges_count(void **state)
{
    (void)state;
    net *n = NULL;
    core_err err;
    net_desc d = { .subprotocol = "strandcast.v3", .port = NET_PORT_ANY };
    assert_int_equal(net_create(&n, &d, &err), CORE_OK);
    for (int i = 0; i < 6; i++) net_publish(n, 3, net_buf_new(8), 10u + (uint64_t)i, i == 0);
    net_drain(n); /* as the net thread does on its wake-up */
    assert_int_equal(n->streams[3].count, 6);
    assert_int_equal(n->streams[3].key_count, 1);
    assert_true(n->streams[3].latest_seq == 15 && n->streams[3].key_seq == 10);
    net_publish(n, 3, net_buf_new(8), 16, false);
    net_drain(n);
    assert_int_equal(n->streams[3].count, 7);
    net_destroy(n);
}

static void test_create_errors(void **state)
{
    (void)state;
    net *n = NULL;
    core_err err;
    net_desc d = { 0 };
    assert_int_equal(net_create(&n, &d, &err), CORE_EINVAL);
    assert_null(n);
    d.subprotocol = "strandcast.v3";
    d.port = 70000;
    assert_int_equal(net_create(&n, &d, &err), CORE_EINVAL);
    /* a free port, then the same port again: the second bind fails with a clear error */
    d.port = NET_PORT_ANY;
    assert_int_equal(net_create(&n, &d, &err), CORE_OK);
    assert_true(net_port(n) > 0);
    net *m = NULL;
    net_desc d2 = d;
    d2.port = net_port(n);
    assert_int_not_equal(net_create(&m, &d2, &err), CORE_OK);
    assert_null(m);
    assert_non_null(strstr(err.msg, "listen"));
    net_destroy(n);
    /* only IP literals of this machine: never a silent fallback to every interface */
    static const char *const bad_addr[] = { "bogus-host", "10.255.255.1", "256.1.1.1" };
    for (size_t i = 0; i < 3; i++) {
        d.listen = bad_addr[i];
        assert_int_not_equal(net_create(&m, &d, &err), CORE_OK);
        assert_null(m);
        assert_non_null(strstr(err.msg, bad_addr[i]));
    }
    d.listen = "::1";
    assert_int_equal(net_create(&n, &d, &err), CORE_OK);
    net_destroy(n);
}

/* The ping interval and hangup time go to lws' idle policy; zero means 20 s and interval + 10 s. */
static void test_ping_policy(void **state)
{
    (void)state;
    net *n = NULL;
    core_err err;
    static const struct { int ping, hangup, want_ping, want_hangup; } ok[] = {
        { 0, 0, 20, 30 },         { 1, 3, 1, 3 },           { 40, 0, 40, 50 },
        { 0, 21, 20, 21 },        { 65530, 0, 65530, 65535 }, { 65534, 65535, 65534, 65535 },
    };
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++) {
        net_desc d = { .subprotocol = "strandcast.v3", .port = NET_PORT_ANY, .ping_s = ok[i].ping,
                       .hangup_s = ok[i].hangup };
        assert_int_equal(net_create(&n, &d, &err), CORE_OK);
        assert_int_equal(n->retry.secs_since_valid_ping, ok[i].want_ping);
        assert_int_equal(n->retry.secs_since_valid_hangup, ok[i].want_hangup);
        net_destroy(n);
    }
    static const int bad[][2] = { { -1, 0 }, { 65535, 0 }, { 0, 20 }, { 0, 5 }, { 5, 5 }, { 0, -1 }, { 1, 65536 } };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        net_desc d = { .subprotocol = "strandcast.v3", .port = NET_PORT_ANY, .ping_s = bad[i][0], .hangup_s = bad[i][1] };
        assert_int_equal(net_create(&n, &d, &err), CORE_EINVAL);
        assert_null(n);
        if (!strstr(err.msg, bad[i][0] < 0 || bad[i][0] > 65534 ? "ping interval" : "hangup"))
            fail_msg("ping %d, hangup %d: %s", bad[i][0], bad[i][1], err.msg);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_token_list),
        cmocka_unit_test(test_buffers),
        cmocka_unit_test(test_create_errors),
        cmocka_unit_test(test_inbox_merges_count),
        cmocka_unit_test(test_ping_policy),
        cmocka_unit_test(test_binds_only_the_address),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
