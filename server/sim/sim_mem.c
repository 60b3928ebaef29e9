/* sim: large solver buffers on transparent huge pages. */
#define _DEFAULT_SOURCE /* madvise, MADV_HUGEPAGE */
#include "sim_mem.h"

#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

void *sim_mem_alloc(size_t bytes, bool zero)
{
    if (bytes < SIM_MEM_HUGE) return zero ? calloc(1, bytes > 0 ? bytes : 1) : malloc(bytes > 0 ? bytes : 1);
    const size_t rounded = (bytes + SIM_MEM_HUGE - 1) / SIM_MEM_HUGE * SIM_MEM_HUGE;
    void *p = aligned_alloc(SIM_MEM_HUGE, rounded);
    if (!p) return NULL;
#ifdef MADV_HUGEPAGE
    (void)madvise(p, rounded, MADV_HUGEPAGE); /* a hint: ordinary pages when refused */
#endif
    if (zero) memset(p, 0, bytes);
    return p;
}
