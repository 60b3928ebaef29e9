/* strandbench: the benchmark entry points and shared measuring helpers. */
#ifndef BENCH_BENCH_H
#define BENCH_BENCH_H

#include <stddef.h>

/* Each takes argv with argv[0] = the benchmark name and returns the process exit code. */
int bench_solver_main(int argc, char **argv);
int bench_fanout_main(int argc, char **argv);
int bench_codec_main(int argc, char **argv);
int bench_quality_main(int argc, char **argv);
int bench_latency_main(int argc, char **argv);
int bench_record_main(int argc, char **argv);

/* Measures memory-copy bandwidth (bytes read + written per second) with a buffer of `bytes`,
 * best of a few runs, on the calling thread plus nthreads-1 helpers. */
double bench_memcpy_bandwidth(size_t bytes, int nthreads);

#endif
