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

void app_world_set_head(app_world *w, core_xform head)
{
    head.rot = core_q_norm(head.rot);
    w->head = head;
    sim_set_motion(&w->sim, head);
}

codec_sim_info app_world_snapshot(const app_world *w)
{
    sim_stats ss;
    sim_get_stats((sim *)&w->sim, &ss);
    const core_xform *h = &w->head;
    return (codec_sim_info){ .sim_time = ss.sim_time, .sim_step = ss.steps,
                             .head_pos = { h->pos.x, h->pos.y, h->pos.z },
                             .head_rot = { h->rot.x, h->rot.y, h->rot.z, h->rot.w } };
}
