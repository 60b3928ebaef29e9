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
int bench_hairmesh_main(int argc, char **argv);

/* Measures memory-copy bandwidth (bytes read + written per second) with a buffer of `bytes`,
 * best of a few runs, on the calling thread plus nthreads-1 helpers. */
double bench_memcpy_bandwidth(size_t bytes, int nthreads);

/* The strandcastd a benchmark runs: `given` when not NULL, else the one in the build folder
 * above this program's (build/tests/strandbench -> build/strandcastd), written into buf (cap
 * bytes), or NULL when it is not there or not executable. Any thread. */
const char *bench_find_daemon(const char *given, char *buf, size_t cap);

#endif
