/* Tests for server/core's pure text helpers: strict UTF-8 validation (what the net layer accepts
 * from clients) and the repair of text cut at a byte count (what the proto layer sends). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <string.h>

#include "core/cli.h"
#include "core/utf8.h"

static const char *const GOOD[] = { "", "plain ascii", "caf\xc3\xa9", "\xe2\x82\xac", "\xf0\x9f\x98\x80",
                                    "\xed\x9f\xbf", "\xee\x80\x80", "\xf4\x8f\xbf\xbf" };
static const char *const BAD[] = {
    "\xff", "\xfe\xff", "\x80", "caf\xc3", "\xc3\x28", "\xc0\xaf" /* overlong '/' */, "\xe0\x80\xaf",
    "\xed\xa0\x80" /* surrogate */, "\xf4\x90\x80\x80" /* > U+10FFFF */, "\xf8\x88\x80\x80\x80", "\xe2\x82",
};

static void test_utf8_valid(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof GOOD / sizeof GOOD[0]; i++) assert_true(core_utf8_valid(GOOD[i], strlen(GOOD[i])));
    for (size_t i = 0; i < sizeof BAD / sizeof BAD[0]; i++)
        if (core_utf8_valid(BAD[i], strlen(BAD[i]))) fail_msg("accepted bad sequence %zu", i);
    /* embedded NUL is valid UTF-8; the length, not the terminator, bounds the check */
    assert_true(core_utf8_valid("a\0b", 3));
    assert_false(core_utf8_valid("ok\xc3\xa9", 3));
}

static void test_utf8_repair(void **state)
{
    (void)state;
    char buf[64];
    /* valid text is left alone */
    for (size_t i = 0; i < sizeof GOOD / sizeof GOOD[0]; i++) {
        snprintf(buf, sizeof buf, "%s", GOOD[i]);
        assert_int_equal(core_utf8_repair(buf, strlen(buf)), 0);
        assert_string_equal(buf, GOOD[i]);
    }
    /* every bad sequence becomes valid, ASCII kept, one '?' per byte that fits no character */
    for (size_t i = 0; i < sizeof BAD / sizeof BAD[0]; i++) {
        snprintf(buf, sizeof buf, "<%s>", BAD[i]);
        size_t n = strlen(buf);
        assert_true(core_utf8_repair(buf, n) > 0);
        assert_true(core_utf8_valid(buf, n));
        assert_int_equal(buf[0], '<');
        assert_int_equal(buf[n - 1], '>');
    }
    snprintf(buf, sizeof buf, "caf\xc3\xa9\xc3\"x");
    assert_int_equal(core_utf8_repair(buf, strlen(buf)), 1);
    assert_string_equal(buf, "caf\xc3\xa9?\"x");
    /* "%.Ns" cutting a two-byte character in half */
    char cut[8];
    snprintf(cut, sizeof cut, "%.4s!", "abc\xc3\xa9");
    assert_int_equal(core_utf8_repair(cut, strlen(cut)), 1);
    assert_string_equal(cut, "abc?!");
}

/* The programs' shared number flags: whole values in range, nothing else (signs, spaces,
 * trailing text, NaN, infinities), each refusal with exit status 2. */
static void test_cli_numbers(void **state)
{
    (void)state;
    unsigned long long u = 7;
    assert_int_equal(core_cli_u64("t", "--n", "0", 0, 10, &u), 0);
    assert_int_equal(u, 0);
    assert_int_equal(core_cli_u64("t", "--n", "10", 0, 10, &u), 0);
    assert_int_equal(u, 10);
    const char *bad_u[] = { "11", "-1", "+1", " 1", "1x", "", "0x5", "99999999999999999999" };
    for (size_t i = 0; i < sizeof bad_u / sizeof bad_u[0]; i++) {
        u = 3;
        assert_int_equal(core_cli_u64("t", "--n", bad_u[i], 0, 10, &u), CORE_CLI_USAGE);
        assert_int_equal(u, 3);
    }
    assert_int_equal(core_cli_u64("t", "--n", NULL, 0, 10, &u), CORE_CLI_USAGE);
    double f = 2;
    assert_int_equal(core_cli_f64("t", "--x", "0.5", 0, 1, &f), 0);
    assert_true(f == 0.5);
    const char *bad_f[] = { "nan", "inf", "-inf", "1.5", "-0.1", "1e999", "0.5s", "" };
    for (size_t i = 0; i < sizeof bad_f / sizeof bad_f[0]; i++) {
        f = 2;
        assert_int_equal(core_cli_f64("t", "--x", bad_f[i], 0, 1, &f), CORE_CLI_USAGE);
        assert_true(f == 2);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cli_numbers),
        cmocka_unit_test(test_utf8_valid),
        cmocka_unit_test(test_utf8_repair),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
