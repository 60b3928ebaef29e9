/* app: record and replay on the sim thread: inputs recorded as they are carried out, replayed
 * inputs carried out at their steps, position digests after each step, the end of a replay. */
#ifndef APP_PLAY_H
#define APP_PLAY_H

#include "app_world.h"

/* Records m (carried out now, before the step after w->step_no steps) when recording. Sim thread. */
void app_play_record(app_world *w, const proto_msg *m);
/* True when m would change the simulation and a replay is running: then m is refused (replied
 * to with bad_state; a set_groom's pending mark dropped). Sim thread. */
bool app_play_refuse(app_world *w, uint32_t client, const proto_msg *m);
/* Carries out the replayed inputs due now; at the recording's end step ends the replay (the
 * daemon pauses and goes live; with --no-net it stops). Sim thread, at a step boundary. */
void app_play_inputs(app_world *w);
/* After a step: counts it, records or checks its digest. A digest that differs from the
 * recording's stops the replay with w->fatal set (CORE_ESTATE). Sim thread. */
core_status app_play_stepped(app_world *w);

#endif
