/* app: the set_groom command on the sim thread: the request checked and handed to the loader
 * thread, then the loaded groom swapped in at a step boundary. */
#ifndef APP_CMD_GROOM_H
#define APP_CMD_GROOM_H

#include "app_world.h"

/* Checks the names (errors are replied at once) and starts the loads on the loader thread; the
 * swap, the replies and the groom broadcast follow in app_cmd_groom_poll. Drops grooms_pending
 * when the request ends, before its replies. Sim thread. */
void app_cmd_set_groom(app_world *w, uint32_t client, const proto_msg *m);
/* Collects a finished groom load: swaps the groom in and replies, or replies the error. True
 * when a new groom was swapped in (its rest pose is then due to be shown: w->dirty). Sim
 * thread, at a step boundary. */
bool app_cmd_groom_poll(app_world *w);

#endif
