/* groom: the default character colliders and point-vs-collider geometry. */
#include "groom.h"
#include "groom_internal.h"

#include <string.h>

void groom_default_colliders(core_groom *g)
{
    memset(g->colliders, 0, sizeof g->colliders);
    core_collider *c = g->colliders;
    c[0].kind = CORE_COLLIDER_ELLIPSOID;
    c[0].a = core_v3(0.0f, 0.0f, 0.0f);
    c[0].radii = core_v3(GROOM_HEAD_RX, GROOM_HEAD_RY, GROOM_HEAD_RZ);
    c[0].rot = core_q_identity();
    c[1].kind = CORE_COLLIDER_CAPSULE; /* neck */
    c[1].a = core_v3(0.0f, -0.06f, -0.01f);
    c[1].b = core_v3(0.0f, -0.20f, -0.01f);
    c[1].radius = 0.05f;
    for (int side = 0; side < 2; side++) { /* shoulders, from the neck base outward */
        float sx = side ? -1.0f : 1.0f;
        core_collider *s = &c[2 + side];
        s->kind = CORE_COLLIDER_CAPSULE;
        s->a = core_v3(0.04f * sx, -0.22f, -0.01f);
        s->b = core_v3(0.19f * sx, -0.25f, -0.01f);
        s->radius = 0.055f;
    }
    for (int i = 0; i < 4; i++) c[i].rot = core_q_identity();
    g->ncolliders = 4;
}

/* Closest point to p on segment a-b. */
static core_vec3 seg_closest(core_vec3 a, core_vec3 b, core_vec3 p)
{
    core_vec3 ab = core_v3_sub(b, a);
    float d = core_v3_dot(ab, ab);
    float t = d > 0.0f ? core_v3_dot(core_v3_sub(p, a), ab) / d : 0.0f;
    if (t < 0.0f) t = 0.0f;
    if (t > 1.0f) t = 1.0f;
    return core_v3_add(a, core_v3_scale(ab, t));
}

static float ell_f(core_vec3 l, core_vec3 r)
{
    float x = l.x / r.x, y = l.y / r.y, z = l.z / r.z;
    return x * x + y * y + z * z;
}

static int round_push(core_vec3 centre, float radius, core_vec3 *p)
{
    core_vec3 d = core_v3_sub(*p, centre);
    float len = core_v3_len(d);
    if (len >= radius) return 0;
    core_vec3 dir = len > 0.0f ? core_v3_scale(d, 1.0f / len) : core_v3(0.0f, 1.0f, 0.0f);
    *p = core_v3_add(centre, core_v3_scale(dir, radius));
    return 1;
}

int groom_collider_push_out(const core_collider *c, core_vec3 *p, float margin)
{
    switch (c->kind) {
    case CORE_COLLIDER_SPHERE: return round_push(c->a, c->radius + margin, p);
    case CORE_COLLIDER_CAPSULE: return round_push(seg_closest(c->a, c->b, *p), c->radius + margin, p);
    case CORE_COLLIDER_ELLIPSOID: {
        core_vec3 l = core_q_rotate(core_q_conj(c->rot), core_v3_sub(*p, c->a));
        core_vec3 r = core_v3(c->radii.x + margin, c->radii.y + margin, c->radii.z + margin);
        float f = ell_f(l, r);
        if (f >= 1.0f) return 0;
        l = f > 0.0f ? core_v3_scale(l, 1.0f / sqrtf(f)) : core_v3(0.0f, r.y, 0.0f);
        *p = core_v3_add(c->a, core_q_rotate(c->rot, l));
        return 1;
    }
    }
    return 0;
}

int groom_collider_contains(const core_collider *c, core_vec3 p)
{
    switch (c->kind) {
    case CORE_COLLIDER_SPHERE: return core_v3_len(core_v3_sub(p, c->a)) < c->radius;
    case CORE_COLLIDER_CAPSULE: return core_v3_len(core_v3_sub(p, seg_closest(c->a, c->b, p))) < c->radius;
    case CORE_COLLIDER_ELLIPSOID:
        return ell_f(core_q_rotate(core_q_conj(c->rot), core_v3_sub(p, c->a)), c->radii) < 1.0f;
    }
    return 0;
}

core_vec3 groom_collider_outward(const core_collider *c, core_vec3 p)
{
    core_vec3 d;
    switch (c->kind) {
    case CORE_COLLIDER_CAPSULE: d = core_v3_sub(p, seg_closest(c->a, c->b, p)); break;
    case CORE_COLLIDER_ELLIPSOID: {
        core_vec3 l = core_q_rotate(core_q_conj(c->rot), core_v3_sub(p, c->a));
        core_vec3 n = core_v3(l.x / (c->radii.x * c->radii.x), l.y / (c->radii.y * c->radii.y),
                              l.z / (c->radii.z * c->radii.z));
        d = core_q_rotate(c->rot, n);
        break;
    }
    default: d = core_v3_sub(p, c->a); break;
    }
    float len = core_v3_len(d);
    return len > 0.0f ? core_v3_scale(d, 1.0f / len) : core_v3(0.0f, 1.0f, 0.0f);
}
