/* app: the client-message parser over the static tables. */
#include "app_anim.h"
#include "app_groom.h"
#include "app_parser.h"
#include "sim/sim.h"

core_status app_parser_init(proto_parser *out, core_err *err)
{
    size_t nparams;
    const core_param_info *ptable = sim_param_table(&nparams);
    if (nparams > PROTO_MAX_PARAMS)
        return core_fail(err, CORE_EINVAL, "the parameter table has %zu entries; proto serves at most %d", nparams,
                         PROTO_MAX_PARAMS);
    *out = (proto_parser){ ptable, nparams, app_preset_names, APP_PRESET_COUNT, app_groom_styles, APP_NSTYLES };
    return CORE_OK;
}
