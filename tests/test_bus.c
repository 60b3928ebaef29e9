/* Tests server/bus: room subjects, messages with headers read back, connecting without a URL and
 * to a server that is not up yet, the shape of credentials files (no nats-server needed: the
 * integration tests run one). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "bus/bus.h"
#include "proto/proto.h"

static void test_subjects(void **state)
{
    (void)state;
    char s[BUS_MAX_SUBJECT];
    assert_true(bus_room_subject(s, sizeof s, "studio-2", "stream.3"));
    assert_string_equal(s, "strandcast.room.studio-2.stream.3");
    /* the longest room name fits with every leaf */
    char room[PROTO_MAX_ROOM + 1];
    memset(room, 'r', PROTO_MAX_ROOM);
    room[PROTO_MAX_ROOM] = '\0';
    assert_true(bus_room_subject(s, sizeof s, room, "stream.31"));
    assert_false(bus_room_subject(s, 20, "studio-2", "ctl"));
}

static void test_headers(void **state)
{
    (void)state;
    natsMsg *m = NULL;
    assert_int_equal(nats_Open(-1), NATS_OK);
    assert_int_equal(natsMsg_Create(&m, "x.y", NULL, "abc", 3), NATS_OK);
    assert_int_equal(natsMsgHeader_Set(m, "Sc-Seq", "18446744073709551615"), NATS_OK);
    assert_int_equal(natsMsgHeader_Set(m, "Sc-Bad", "12x"), NATS_OK);
    assert_int_equal(natsMsgHeader_Set(m, "Sc-Op", "open"), NATS_OK);
    assert_true(bus_header_u64(m, "Sc-Seq", 0) == UINT64_MAX);
    assert_true(bus_header_u64(m, "Sc-Bad", 7) == 7);
    assert_true(bus_header_u64(m, "Sc-None", 9) == 9);
    assert_string_equal(bus_header(m, "Sc-Op"), "open");
    assert_null(bus_header(m, "Sc-None"));
    natsMsg_Destroy(m);
}

/* No URL: refused. A server that is not up: the connection is made in the background (a node or
 * an edge may start before nats-server), publishing before it is up says so, and closing it
 * before it came up is clean. */
static void test_connect(void **state)
{
    (void)state;
    natsConnection *nc = NULL;
    core_err err;
    bus_desc d = { .url = NULL };
    assert_int_equal(bus_connect(&nc, &d, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "URL"));
    d.url = "nats://127.0.0.1:1";
    assert_int_equal(bus_connect(&nc, &d, &err), CORE_OK);
    assert_non_null(nc);
    assert_false(natsConnection_Status(nc) == NATS_CONN_STATUS_CONNECTED);
    /* until it is up, a message with headers is refused as "not yet", not as a failure */
    const char *h[] = { "Sc-Op", "blob", NULL };
    assert_int_equal(bus_publish(nc, "strandcast.room.r.blob", h, "x", 1, &err), CORE_ESTATE);
    assert_non_null(strstr(err.msg, "not connected to NATS yet"));
    bus_close(nc, NULL, 0);
}

/* path holds text (fails the test otherwise). */
static void put(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fputs(text, f) >= 0, 1);
    assert_int_equal(fclose(f), 0);
}

/* A credentials file in nsc's layout passes; one without the JWT or the seed, a seed of another
 * kind (an account's), a folder or a missing file fail with the reason. */
static void test_creds_check(void **state)
{
    (void)state;
    char dir[] = "/tmp/strandcast-bus-creds-XXXXXX", path[64];
    assert_non_null(mkdtemp(dir));
    snprintf(path, sizeof path, "%s/u.creds", dir);
    static const char jwt[] = "-----BEGIN NATS USER JWT-----\neyJ0eXAiOiJKV1QifQ.eyJzdWIiOiJVIn0.c2lnbmF0dXJl\n"
                              "------END NATS USER JWT------\n\n";
    static const char seed[] = "-----BEGIN USER NKEY SEED-----\nSUAMLK2ZNL35WSMW37E7UD4VZ7ELPKW7DHC3BWBSD2GCZ7IUQQXZIORRBU\n"
                               "------END USER NKEY SEED------\n";
    char text[512];
    core_err err;
    snprintf(text, sizeof text, "%s%s", jwt, seed);
    put(path, text);
    assert_int_equal(bus_creds_check(path, &err), CORE_OK);
    put(path, seed);
    assert_int_equal(bus_creds_check(path, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "no user JWT"));
    put(path, jwt);
    assert_int_equal(bus_creds_check(path, &err), CORE_EINVAL);
    assert_non_null(strstr(err.msg, "no NKey user seed"));
    snprintf(text, sizeof text, "%sSAAMLK2ZNL35WSMW37E7UD4VZ7ELPKW7DHC3BWBSD2GCZ7IUQQXZIORRBU\n", jwt);
    put(path, text);
    assert_int_equal(bus_creds_check(path, &err), CORE_EINVAL);
    assert_int_equal(bus_creds_check(dir, &err), CORE_EIO);
    assert_non_null(strstr(err.msg, "directory"));
    unlink(path);
    assert_int_equal(bus_creds_check(path, &err), CORE_EIO);
    assert_non_null(strstr(err.msg, "No such file"));
    rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_subjects),
        cmocka_unit_test(test_headers),
        cmocka_unit_test(test_connect),
        cmocka_unit_test(test_creds_check),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
