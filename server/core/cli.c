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

void core_cli_begin(void)
{
    optind = 1;
    opterr = 0;
}

int core_cli_next(const char *prog, int argc, char *argv[], const struct option *opts, char *flag, size_t cap,
                  int *status)
{
    int index = 0;
    int opt = getopt_long(argc, argv, ":h", opts, &index);
    *status = 0;
    if (opt == -1) {
        if (optind >= argc) return -1;
        *status = core_cli_bad(prog, argv[optind], NULL, "unexpected argument (flags start with --)");
        return 0;
    }
    if (opt == '?' || opt == ':') {
        *status = core_cli_getopt_error(prog, opt, argv);
        return 0;
    }
    snprintf(flag, cap, "--%s", opt == 'h' ? "help" : opts[index].name);
    return opt;
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
