/* Tests of the solver's large-buffer allocator: zeroed on request, huge-page aligned from
 * SIM_MEM_HUGE up, and usable to its last byte (ASan checks the bounds). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdlib.h>
#include <string.h>

#include "sim/sim_mem.h"

/* Every byte of p[0, n) is zero. */
static bool all_zero(const unsigned char *p, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (p[i]) return false;
    return true;
}

static void test_zeroed_and_aligned(void **state)
{
    (void)state;
    const size_t sizes[] = { 0, 1, 4096, SIM_MEM_HUGE - 1, SIM_MEM_HUGE, SIM_MEM_HUGE + 12345, 3 * SIM_MEM_HUGE };
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        unsigned char *p = sim_mem_alloc(sizes[k], true);
        assert_non_null(p);
        assert_true(all_zero(p, sizes[k]));
        if (sizes[k] >= SIM_MEM_HUGE) assert_int_equal((uintptr_t)p % SIM_MEM_HUGE, 0);
        if (sizes[k] > 0) memset(p, 0xab, sizes[k]); /* the whole buffer is writable */
        free(p);
    }
}

static void test_uncleared_is_writable(void **state)
{
    (void)state;
    const size_t n = SIM_MEM_HUGE + 4096;
    unsigned char *p = sim_mem_alloc(n, false);
    assert_non_null(p);
    memset(p, 0x5a, n);
    assert_int_equal(p[n - 1], 0x5a);
    free(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_zeroed_and_aligned),
        cmocka_unit_test(test_uncleared_is_writable),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
