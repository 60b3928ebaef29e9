/* Integration tests: the real strandcastd on a free loopback port, driven by real WebSocket clients.
 * usage: it_net STRANDCASTD [TEST-NAME-PATTERN]; the scenarios are listed in scenarios.h. */
#include <signal.h>
#include <stdio.h>

#include "it.h"

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s STRANDCASTD [TEST]\n", argv[0]);
        return 2;
    }
    static config cfg;
    cfg.exe = argv[1];
    if (argc > 2) cmocka_set_test_filter(argv[2]);
    signal(SIGPIPE, SIG_IGN);
#define IT_SCENARIO(name, su, td, timeout, labels) cmocka_unit_test_prestate_setup_teardown(test_##name, su, td, &cfg),
    const struct CMUnitTest tests[] = {
#include "scenarios.h"
    };
#undef IT_SCENARIO
    return cmocka_run_group_tests(tests, NULL, NULL);
}
