/* sim: large solver buffers on transparent huge pages. */
#ifndef SIM_SIM_MEM_H
#define SIM_SIM_MEM_H

#include <stdbool.h>
#include <stddef.h>

/* The huge page size asked for. */
#define SIM_MEM_HUGE ((size_t)2 << 20)

/* bytes of memory (zeroed with zero), released with free(); NULL when out of memory. A buffer
 * of at least SIM_MEM_HUGE bytes is aligned to it and asks the kernel for huge pages
 * (madvise MADV_HUGEPAGE: the solver's per-level and neighbour accesses stride across more 4 KiB
 * pages than the TLB holds); a refusal leaves it on ordinary pages. Any thread. */
void *sim_mem_alloc(size_t bytes, bool zero);

#endif
