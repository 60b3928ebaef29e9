/* core: what the command-line programs share when they read their flags (with getopt_long):
 * one error style ("PROG: FLAG VALUE: WHY" and "Try 'PROG --help'." on stderr) and one exit
 * status for bad flags. Pure apart from writing stderr; any thread. */
#ifndef CORE_CLI_H
#define CORE_CLI_H

#include <getopt.h>
#include <stdbool.h>

#define CORE_CLI_USAGE 2 /* exit status of every program for bad flags */

/* Reports a bad flag; returns CORE_CLI_USAGE. value may be NULL. */
int core_cli_bad(const char *prog, const char *flag, const char *value, const char *why);
/* Reports what getopt_long (optstring starting with ':', opterr 0) returned for opt '?' (an
 * unknown flag, or a value given to a flag that takes none) or ':' (a missing value), naming
 * the flag as the user wrote it; returns CORE_CLI_USAGE. */
int core_cli_getopt_error(const char *prog, int opt, char *const argv[]);
/* Starts reading argv with core_cli_next (resets getopt's state and its own messages). */
void core_cli_begin(void);
/* The next flag of argv per opts (getopt_long, short option 'h' only): its val, with its name
 * written "--name" into flag (cap bytes); -1 after the last; 0 for an unknown flag, a missing
 * value or a value given to a flag that takes none, or an argument that is no flag (reported
 * with core_cli_bad, *status set to the exit status). */
int core_cli_next(const char *prog, int argc, char *argv[], const struct option *opts, char *flag, size_t cap,
                  int *status);
/* Parses v as a decimal integer in [lo, hi] (no sign, no trailing text) into *out: 0, or
 * core_cli_bad's status. */
int core_cli_u64(const char *prog, const char *flag, const char *v, unsigned long long lo, unsigned long long hi,
                 unsigned long long *out);
/* Parses v as a finite number in [lo, hi] into *out: 0, or core_cli_bad's status. */
int core_cli_f64(const char *prog, const char *flag, const char *v, double lo, double hi, double *out);

#endif
