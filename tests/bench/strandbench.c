/* strandbench: benchmark driver; the first argument picks the benchmark (solver by default). */
#include <stdio.h>
#include <string.h>

#include "bench.h"

int main(int argc, char **argv)
{
    if (argc > 1 && (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0)) {
        puts("usage: strandbench [solver|codec|fanout|quality|latency|record|hairmesh] [options]   (strandbench COMMAND --help for each)\n"
             "  solver   the hair solver's steps/s per scene and backend (the default)\n"
             "  codec    strand-frame codec vs baselines on simulated frames: size, error, C and JS speed\n"
             "  fanout   strandcastd streaming to 1..N loopback clients: sim steps/s, frames per client, CPU\n"
             "  quality  how the hair behaves per groom x parameter value x head motion: stillness at rest,\n"
             "           settling time, stretch, penetration, shape kept, tips up, SPH volume\n"
             "  latency  strandcastd on loopback: parameter change to the first frame showing it, p50/p99\n"
             "  record   what strandcastd --record costs a step of the default scene (budget 2%)\n"
             "  hairmesh the hair-mesh solver's ms per frame and per stage on the 2016 paper's mesh sizes");
        return 0;
    }
    if (argc > 1 && strcmp(argv[1], "codec") == 0) return bench_codec_main(argc - 1, argv + 1);
    if (argc > 1 && strcmp(argv[1], "fanout") == 0) return bench_fanout_main(argc - 1, argv + 1);
    if (argc > 1 && strcmp(argv[1], "quality") == 0) return bench_quality_main(argc - 1, argv + 1);
    if (argc > 1 && strcmp(argv[1], "latency") == 0) return bench_latency_main(argc - 1, argv + 1);
    if (argc > 1 && strcmp(argv[1], "hairmesh") == 0) return bench_hairmesh_main(argc - 1, argv + 1);
    if (argc > 1 && strcmp(argv[1], "record") == 0) return bench_record_main(argc - 1, argv + 1);
    if (argc > 1 && strcmp(argv[1], "solver") == 0) return bench_solver_main(argc - 1, argv + 1);
    return bench_solver_main(argc, argv);
}
