/* strandbench: the memory-bandwidth yardstick (a large memcpy, all workers in parallel). */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bench.h"
#include "core/core.h"

typedef struct copy_job {
    char *dst;
    const char *src;
    size_t bytes;
} copy_job;

static void *copy_main(void *arg)
{
    copy_job *j = arg;
    memcpy(j->dst, j->src, j->bytes);
    return NULL;
}

double bench_memcpy_bandwidth(size_t bytes, int nthreads)
{
    if (nthreads <= 0) {
        long n = sysconf(_SC_NPROCESSORS_ONLN);
        nthreads = n > 0 ? (int)n : 1;
    }
    if (nthreads > 64) nthreads = 64;
    char *src = malloc(bytes), *dst = malloc(bytes);
    if (!src || !dst) {
        free(src);
        free(dst);
        return 1e9;
    }
    memset(src, 1, bytes);
    memset(dst, 2, bytes);
    double best = 0.0;
    for (int rep = 0; rep < 5; rep++) {
        pthread_t th[64];
        copy_job jobs[64];
        size_t part = bytes / (size_t)nthreads;
        unsigned long long t0 = core_now_ns();
        for (int t = 0; t < nthreads; t++) {
            jobs[t] = (copy_job){ dst + part * t, src + part * t, part };
            if (t > 0) pthread_create(&th[t], NULL, copy_main, &jobs[t]);
        }
        copy_main(&jobs[0]);
        for (int t = 1; t < nthreads; t++) pthread_join(th[t], NULL);
        double sec = (double)(core_now_ns() - t0) * 1e-9;
        double bw = 2.0 * (double)(part * (size_t)nthreads) / sec;
        if (bw > best) best = bw;
    }
    free(src);
    free(dst);
    return best;
}
