/* core: status codes, error message buffers and logging shared by every module. */
#ifndef CORE_CORE_H
#define CORE_CORE_H

#include <stdarg.h>
#include <stddef.h>

typedef enum core_status {
    CORE_OK = 0,
    CORE_EINVAL,      /* bad argument or out-of-range value */
    CORE_ENOMEM,      /* allocation failed or size overflow */
    CORE_EIO,         /* file or socket error */
    CORE_EFORMAT,     /* malformed input data (file, frame, message) */
    CORE_EUNSUPPORTED,/* valid request the build or device cannot serve */
    CORE_EBACKEND,    /* a compute backend (Vulkan, threads) failed */
    CORE_ESTATE,      /* call not valid in the current state */
    CORE_ECANCELED    /* the work was abandoned on request and undone (sim_set_cancel); not a failure */
} core_status;

#define CORE_ERR_MAX 256

/* A human-readable error message; filled by the callee when it returns non-OK.
 * Callers own it (usually on the stack) and may pass NULL when they do not care. */
typedef struct core_err {
    char msg[CORE_ERR_MAX];
} core_err;

/* Formats a message into err (if non-NULL) and returns st. Any thread. */
core_status core_fail(core_err *err, core_status st, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Stable lowercase name of a status ("invalid_argument", ...); static storage. */
const char *core_status_name(core_status st);

typedef enum core_log_level { CORE_LOG_DEBUG, CORE_LOG_INFO, CORE_LOG_WARN, CORE_LOG_ERROR } core_log_level;

/* Writes one timestamped line to stderr, e.g. "12:00:01.123 info  sim: 60.0 steps/s".
 * Thread-safe (one fprintf per line). */
void core_log(core_log_level level, const char *module, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Monotonic clock in nanoseconds. Any thread. */
unsigned long long core_now_ns(void);

/* Overflow-checked a*b for sizes; returns 0 and leaves *out untouched on overflow. */
int core_mul_size(size_t a, size_t b, size_t *out);

#endif
