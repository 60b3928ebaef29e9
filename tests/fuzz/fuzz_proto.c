/* fuzz_proto: libFuzzer target for proto_parse, the control-message parser, with the daemon's
 * own tables (sim_param_table, the animation presets, the procedural style names). */
#include <stddef.h>
#include <stdint.h>

#include "app/app_anim.h"
#include "groom/groom.h"
#include "proto/proto.h"
#include "sim/sim.h"

#define FUZZ_NSTYLES 3

/* One input = one client text message; any outcome but a clean CORE_OK or CORE_EINVAL with a
 * reason is a bug (the sanitizers catch memory errors and undefined behaviour). */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    size_t nparams;
    const core_param_info *params = sim_param_table(&nparams);
    const char *styles[FUZZ_NSTYLES];
    for (int i = 0; i < FUZZ_NSTYLES; i++) styles[i] = groom_style_name((groom_style)i);
    const proto_parser p = { params, nparams, app_preset_names, APP_PRESET_COUNT, styles, FUZZ_NSTYLES };
    proto_msg msg;
    proto_error e;
    core_status st = proto_parse(&p, (const char *)data, size, &msg, &e);
    if (st != CORE_OK && (st != CORE_EINVAL || e.code == PROTO_ERR_NONE || e.message[0] == '\0'))
        __builtin_trap();
    return 0;
}
