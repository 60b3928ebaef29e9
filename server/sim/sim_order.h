/* sim: the shared strand order (Morton order of the roots). */
#ifndef SIM_SIM_ORDER_H
#define SIM_SIM_ORDER_H

#include <stdint.h>

#include "../core/groom_types.h"

/* Sets *out to a malloc'd permutation of g's strands (internal index -> groom strand), roots
 * in Morton order over their bounding box, ties by strand index. Caller frees. Pure, any thread. */
core_status sim_strand_order(const core_groom *g, uint32_t **out, core_err *err);

#endif
