/* app: the sim thread's world: reset and run state. */
#include "app_world.h"

void app_world_reset(app_world *w)
{
    sim_reset(&w->sim);
    pthread_mutex_lock(&w->board->mu);
    w->board->s.nan_resets = 0;
    pthread_mutex_unlock(&w->board->mu);
}

proto_state app_world_state(const app_world *w)
{
    sim_stats ss;
    sim_get_stats((sim *)&w->sim, &ss);
    proto_state s = { w->paused, ss.sim_time, ss.steps, { app_preset_names[w->anim.preset], w->anim.speed } };
    return s;
}
