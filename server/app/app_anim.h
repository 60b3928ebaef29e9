/* app: the head's motion: the preset animations (names, pure head-transform functions of time)
 * and the sim thread's animation state (client base pose, running preset, blend between
 * presets). Depends on core only. */
#ifndef APP_ANIM_H
#define APP_ANIM_H

#include <stdbool.h>

#include "core/math3.h"

typedef enum app_preset { APP_PRESET_NONE, APP_PRESET_NOD, APP_PRESET_SHAKE, APP_PRESET_CIRCLE,
                          APP_PRESET_HEADBANG, APP_PRESET_SWAY, APP_PRESET_COUNT } app_preset;

/* The presets' names, indexed by app_preset ("none", "nod", ...); static storage. */
extern const char *const app_preset_names[APP_PRESET_COUNT];

/* The head transform of preset p at animation time t (s) applied on top of base. Pure, any
 * thread. */
core_xform app_anim_head(app_preset p, double t, core_xform base);

/* Seconds (of simulated time, whatever the speed) over which a change of preset blends from
 * the head pose at the change to the new motion. */
#define APP_ANIM_BLEND_S 0.4

/* The head animation (sim thread): the client's base pose, the running preset and the blend
 * from the pose the head had at the last change of preset. */
typedef struct app_anim {
    core_xform base;          /* last client motion */
    app_preset preset;
    double speed, time;       /* time: the preset's clock, s (advances by dt * speed) */
    core_xform from;          /* head pose at the last change of preset */
    double since;             /* simulated seconds since that change; >= APP_ANIM_BLEND_S: done */
} app_anim;

/* from moved toward to by weight w in [0, 1] (clamped): position lerp, rotation nlerp along the
 * shorter arc; w = 0 gives from, w = 1 gives to. Pure. */
core_xform app_anim_blend(core_xform from, core_xform to, double w);
/* The blend weight after `since` seconds of a change: smoothstep of since / APP_ANIM_BLEND_S
 * (0 at the change, 1 from APP_ANIM_BLEND_S on, zero slope at both ends). Pure. */
double app_anim_blend_weight(double since);
/* No preset, speed 1, identity base, no blend running. */
void app_anim_init(app_anim *s);
/* The head pose now: the preset on the base, blended from s->from while a blend runs. Pure. */
core_xform app_anim_pose(const app_anim *s);
/* Starts preset p (APP_PRESET_NONE stops) at speed from preset time 0, blending from the
 * current pose. Every call is a change, even to the running preset. Sim thread. */
void app_anim_start(app_anim *s, app_preset p, double speed);
/* A client motion: the new base. A running preset stops (blending from the current pose to
 * the new base); returns true when it did. Without a preset the head follows the base at once
 * (or the running blend heads for the new base). Sim thread. */
bool app_anim_motion(app_anim *s, core_xform base);
/* Advances the preset clock by dt * speed and the blend by dt (s). Sim thread. */
void app_anim_advance(app_anim *s, double dt);

#endif
