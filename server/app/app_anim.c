/* app: preset head animations (nod, shake, circle, headbang, sway) as pure functions of time,
 * and the blend that makes a change of preset continuous. */
#include <math.h>

#include "app_anim.h"

const char *const app_preset_names[APP_PRESET_COUNT] = { "none", "nod", "shake", "circle", "headbang", "sway" };

#define TWO_PI 6.283185307179586

/* Rotation by angle about axis through the neck pivot (head frame, below the skull). */
static core_xform about_neck(core_vec3 axis, double angle)
{
    const core_vec3 pivot = { 0.0f, -0.12f, 0.0f };
    core_xform x;
    x.rot = core_q_axis_angle(axis, (float)angle);
    /* p' = R (p - pivot) + pivot */
    x.pos = core_v3_sub(pivot, core_q_rotate(x.rot, pivot));
    return x;
}

core_xform app_anim_head(app_preset p, double t, core_xform base)
{
    core_xform off = core_xform_identity();
    switch (p) {
    case APP_PRESET_NONE:
    case APP_PRESET_COUNT: return base;
    case APP_PRESET_NOD: off = about_neck(core_v3(1, 0, 0), 0.30 * sin(TWO_PI * 0.5 * t)); break;
    case APP_PRESET_SHAKE: off = about_neck(core_v3(0, 1, 0), 0.60 * sin(TWO_PI * 0.6 * t)); break;
    case APP_PRESET_CIRCLE:
        off.pos = core_v3((float)(0.06 * sin(TWO_PI * 0.5 * t)), 0.0f, (float)(0.06 * (cos(TWO_PI * 0.5 * t) - 1.0)));
        break;
    case APP_PRESET_HEADBANG: off = about_neck(core_v3(1, 0, 0), 0.45 * (0.5 - 0.5 * cos(TWO_PI * 2.0 * t))); break;
    case APP_PRESET_SWAY: off = about_neck(core_v3(0, 0, 1), 0.25 * sin(TWO_PI * 0.4 * t)); break;
    }
    /* world = base * off: the preset moves the head relative to the client's base pose */
    core_xform r;
    r.rot = core_q_norm(core_q_mul(base.rot, off.rot));
    r.pos = core_v3_add(core_q_rotate(base.rot, off.pos), base.pos);
    return r;
}

core_xform app_anim_blend(core_xform from, core_xform to, double w)
{
    float t = (float)(w < 0.0 ? 0.0 : w > 1.0 ? 1.0 : w);
    if (t <= 0.0f) return from;
    if (t >= 1.0f) return to;
    return core_xform_lerp(from, to, t);
}

double app_anim_blend_weight(double since)
{
    double u = since / APP_ANIM_BLEND_S;
    if (!(u > 0.0)) return 0.0;
    if (u >= 1.0) return 1.0;
    return u * u * (3.0 - 2.0 * u);
}

void app_anim_init(app_anim *s)
{
    s->base = core_xform_identity();
    s->preset = APP_PRESET_NONE;
    s->speed = 1.0;
    s->time = 0.0;
    s->from = s->base;
    s->since = APP_ANIM_BLEND_S;
}

core_xform app_anim_pose(const app_anim *s)
{
    core_xform to = app_anim_head(s->preset, s->time, s->base);
    return app_anim_blend(s->from, to, app_anim_blend_weight(s->since));
}

void app_anim_start(app_anim *s, app_preset p, double speed)
{
    s->from = app_anim_pose(s);
    s->since = 0.0;
    s->preset = p;
    s->speed = speed;
    s->time = 0.0;
}

bool app_anim_motion(app_anim *s, core_xform base)
{
    bool stopped = s->preset != APP_PRESET_NONE;
    if (stopped) app_anim_start(s, APP_PRESET_NONE, s->speed);
    s->base = base;
    return stopped;
}

void app_anim_advance(app_anim *s, double dt)
{
    s->time += dt * s->speed;
    if (s->since < APP_ANIM_BLEND_S) s->since += dt;
}
