/* app: client commands, carried out on the sim thread at a step boundary: their effects on the
 * world, their replies and the announcements to every client. */
#ifndef APP_CMD_H
#define APP_CMD_H

#include "app_cmd_groom.h"
#include "app_world.h"

/* Carries out one command from the mailbox. Sim thread. */
void app_cmd_handle(app_world *w, app_cmd *c);
/* Tells client (or every subscriber of the stream, with NET_ALL) that the stream's frames are
 * not being sent because they cannot be encoded; nothing while it encodes. */
void app_cmd_tell_failure(app_world *w, int stream, uint32_t client);
/* When the active solver no longer simulates a hair mesh (a solver or groom change), moves every
 * client on a hair mesh stream to the strand stream of its settings and tells it (an unsolicited
 * subscribed, before its first strand frame). Sim thread. */
void app_cmd_hairmesh_fallback(app_world *w);

#endif
