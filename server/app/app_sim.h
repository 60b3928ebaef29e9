/* app: the sim thread's loop: commands at step boundaries, fixed steps in real time,
 * publishing rounds, stats windows. */
#ifndef APP_SIM_H
#define APP_SIM_H

#include "app_world.h"

/* The sim thread's body (pthread start routine; arg = the app_world, which it owns until it
 * returns). Runs until w->quit, d->steps steps, or a failed step (w->fatal); sets w->done. */
void *app_sim_main(void *arg);

/* Lets steps of w->sim be abandoned for a queued parameter change (sim_set_cancel; not while
 * replaying). Called for every simulation the sim thread takes over. Sim thread. */
void app_sim_arm(app_world *w);

#endif
