/* app: the preset head animations (names and pure head-transform functions of time). */
#ifndef APP_ANIM_H
#define APP_ANIM_H

#include "core/math3.h"

typedef enum app_preset { APP_PRESET_NONE, APP_PRESET_NOD, APP_PRESET_SHAKE, APP_PRESET_CIRCLE,
                          APP_PRESET_HEADBANG, APP_PRESET_SWAY, APP_PRESET_COUNT } app_preset;

/* The presets' names, indexed by app_preset ("none", "nod", ...); static storage. */
extern const char *const app_preset_names[APP_PRESET_COUNT];

/* The head transform of preset p at animation time t (s) applied on top of base. Pure, any
 * thread. */
core_xform app_anim_head(app_preset p, double t, core_xform base);

#endif
