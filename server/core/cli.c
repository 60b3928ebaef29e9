/* core: the command-line programs' shared flag errors and number parsing. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"

int core_cli_bad(const char *prog, const char *flag, const char *value, const char *why)
{
    fprintf(stderr, "%s: %s%s%s: %s\nTry '%s --help'.\n", prog, flag, value ? " " : "", value ? value : "", why, prog);
    return CORE_CLI_USAGE;
}

int core_cli_getopt_error(const char *prog, int opt, char *const argv[])
{
    const char *arg = optind > 0 ? argv[optind - 1] : "";
    char flag[64];
    const char *eq = strchr(arg, '=');
    size_t n = eq && strncmp(arg, "--", 2) == 0 ? (size_t)(eq - arg) : strlen(arg);
    snprintf(flag, sizeof flag, "%.*s", (int)(n < sizeof flag ? n : sizeof flag - 1), arg);
    if (opt == ':') return core_cli_bad(prog, flag, NULL, "needs a value");
    if (eq && optopt != 0) return core_cli_bad(prog, flag, eq + 1, "takes no value");
    return core_cli_bad(prog, flag, NULL, "unknown option");
}

int core_cli_u64(const char *prog, const char *flag, const char *v, unsigned long long lo, unsigned long long hi,
                 unsigned long long *out)
{
    char why[96];
    snprintf(why, sizeof why, "expected an integer in [%llu, %llu]", lo, hi);
    if (!v || !(*v >= '0' && *v <= '9')) return core_cli_bad(prog, flag, v, why); /* no sign, no space */
    errno = 0;
    char *end;
    unsigned long long x = strtoull(v, &end, 10);
    if (errno || *end || x < lo || x > hi) return core_cli_bad(prog, flag, v, why);
    *out = x;
    return 0;
}

int core_cli_f64(const char *prog, const char *flag, const char *v, double lo, double hi, double *out)
{
    char why[96];
    snprintf(why, sizeof why, "expected a number in [%g, %g]", lo, hi);
    if (!v || !*v) return core_cli_bad(prog, flag, v, why);
    errno = 0;
    char *end;
    double x = strtod(v, &end);
    if (errno || *end || !(x >= lo && x <= hi)) return core_cli_bad(prog, flag, v, why);
    *out = x;
    return 0;
}
