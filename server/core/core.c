/* core: status names, error formatting, logging and the monotonic clock. */
#define _POSIX_C_SOURCE 200809L
#include "core.h"

#include <stdint.h>
#include <stdio.h>
#include <time.h>

core_status core_fail(core_err *err, core_status st, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->msg, sizeof err->msg, fmt, ap);
        va_end(ap);
    }
    return st;
}

const char *core_status_name(core_status st)
{
    switch (st) {
    case CORE_OK: return "ok";
    case CORE_EINVAL: return "invalid_argument";
    case CORE_ENOMEM: return "out_of_memory";
    case CORE_EIO: return "io_error";
    case CORE_EFORMAT: return "bad_format";
    case CORE_EUNSUPPORTED: return "unsupported";
    case CORE_EBACKEND: return "backend_error";
    case CORE_ESTATE: return "bad_state";
    case CORE_ECANCELED: return "canceled";
    }
    return "unknown";
}

void core_log(core_log_level level, const char *module, const char *fmt, ...)
{
    static const char *names[] = { "debug", "info ", "warn ", "error" };
    char line[1024];
    struct timespec ts;
    struct tm tm;
    clock_gettime(CLOCK_REALTIME, &ts);
    localtime_r(&ts.tv_sec, &tm);
    int n = snprintf(line, sizeof line, "%02d:%02d:%02d.%03ld %s %s: ", tm.tm_hour, tm.tm_min,
                     tm.tm_sec, ts.tv_nsec / 1000000L, names[level], module);
    if (n < 0 || (size_t)n >= sizeof line) n = 0;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line + n, sizeof line - (size_t)n, fmt, ap);
    va_end(ap);
    fprintf(stderr, "%s\n", line);
}

unsigned long long core_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (unsigned long long)ts.tv_sec * 1000000000ull + (unsigned long long)ts.tv_nsec;
}

int core_mul_size(size_t a, size_t b, size_t *out)
{
    if (a != 0 && b > SIZE_MAX / a) return 0;
    *out = a * b;
    return 1;
}
