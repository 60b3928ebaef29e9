/* groom: the procedural default groom (scalp roots on a head ellipsoid, draped strands). */
#include "groom.h"
#include "groom_internal.h"

#include <math.h>
#include <string.h>

#define PI_F 3.14159265358979f
#define ROOT_LIFT 0.001f      /* roots sit this far outside the head ellipsoid, m */
#define DRAPE_MARGIN 0.001f   /* vertices are kept this far outside every collider, m */
#define LENGTH_JITTER 0.08f   /* per-strand length variation, fraction */
#define COMB_RADIUS 0.015f    /* smallest bend radius while a strand turns toward its fall direction, m */
#define STYLE_RAMP 0.04f      /* waves and curls fade in over this arc length from the root */
#define WAVE_AMPLITUDE 0.008f
#define WAVE_LENGTH (0.25f / 3.5f)
#define CURL_RADIUS 0.01f
#define CURL_PITCH 0.025f

typedef struct strand_ctx {
    const core_groom *g;
    groom_style style;
    float seg;          /* segment length of this strand */
    float phase;        /* wave / curl phase */
    core_vec3 root, normal, fall;
} strand_ctx;

/* Scalp = upper part of the head, reaching lower at the back, excluding the face (+z). */
static int on_scalp(core_vec3 u)
{
    float back = u.z < 0.0f ? -u.z : 0.0f;
    if (u.y < 0.05f - 0.4f * back) return 0;
    if (u.z > 0.45f && u.y < 0.5f) return 0;
    return 1;
}

static core_vec3 random_unit(groom_rng *r)
{
    float y = 2.0f * groom_rng_float(r) - 1.0f;
    float phi = 2.0f * PI_F * groom_rng_float(r);
    float s = sqrtf(fmaxf(0.0f, 1.0f - y * y));
    return core_v3(s * cosf(phi), y, s * sinf(phi));
}

/* Picks a root on the scalp, its surface normal and the direction its strand falls in. */
static void pick_root(groom_rng *r, strand_ctx *c)
{
    core_vec3 u;
    do u = random_unit(r);
    while (!on_scalp(u));
    core_vec3 e = core_v3(GROOM_HEAD_RX * u.x, GROOM_HEAD_RY * u.y, GROOM_HEAD_RZ * u.z);
    c->normal = core_v3_norm(core_v3(e.x / (GROOM_HEAD_RX * GROOM_HEAD_RX), e.y / (GROOM_HEAD_RY * GROOM_HEAD_RY),
                                     e.z / (GROOM_HEAD_RZ * GROOM_HEAD_RZ)));
    c->root = core_v3_add(e, core_v3_scale(c->normal, ROOT_LIFT));
    core_vec3 h = core_v3(c->normal.x, 0.0f, c->normal.z);
    h = core_v3_len(h) > 1e-3f ? core_v3_norm(h) : core_v3(0.0f, 0.0f, -1.0f);
    core_vec3 jitter = core_v3(0.1f * (groom_rng_float(r) - 0.5f), 0.0f, 0.1f * (groom_rng_float(r) - 0.5f));
    c->fall = core_v3_norm(core_v3_add(core_v3_add(core_v3_scale(h, 0.3f), core_v3(0.0f, -1.0f, 0.0f)), jitter));
}

/* Direction of the next segment: the combed centre direction plus the style's offset. */
static core_vec3 style_dir(const strand_ctx *c, core_vec3 dir, core_vec3 n, float s)
{
    if (c->style == GROOM_STRAIGHT) return dir;
    float x = s / STYLE_RAMP;
    float ramp = x >= 1.0f ? 1.0f : x * x * (3.0f - 2.0f * x);
    if (c->style == GROOM_WAVY) {
        float slope = WAVE_AMPLITUDE * 2.0f * PI_F / WAVE_LENGTH * cosf(2.0f * PI_F * s / WAVE_LENGTH + c->phase);
        float beta = ramp * atanf(slope);
        return core_v3_add(core_v3_scale(dir, cosf(beta)), core_v3_scale(n, sinf(beta)));
    }
    float turn = sqrtf(4.0f * PI_F * PI_F * CURL_RADIUS * CURL_RADIUS + CURL_PITCH * CURL_PITCH);
    float alpha = ramp * atanf(2.0f * PI_F * CURL_RADIUS / CURL_PITCH);
    float theta = 2.0f * PI_F * s / turn + c->phase;
    core_vec3 b = core_v3_cross(dir, n);
    core_vec3 side = core_v3_add(core_v3_scale(n, cosf(theta)), core_v3_scale(b, sinf(theta)));
    return core_v3_add(core_v3_scale(dir, cosf(alpha)), core_v3_scale(side, sinf(alpha)));
}

/* Places p = prev + seg * (unit direction) outside every collider: project out with a margin,
 * renormalise the segment, repeat; as a last resort step along the outward normal. */
static core_vec3 drape(const strand_ctx *c, core_vec3 prev, core_vec3 p)
{
    const core_groom *g = c->g;
    for (int iter = 0; iter < 16; iter++) {
        int moved = 0;
        for (uint32_t k = 0; k < g->ncolliders; k++) moved |= groom_collider_push_out(&g->colliders[k], &p, DRAPE_MARGIN);
        if (!moved) return p;
        core_vec3 d = core_v3_sub(p, prev);
        float len = core_v3_len(d);
        if (!(len > 0.0f)) break;
        p = core_v3_add(prev, core_v3_scale(d, c->seg / len));
    }
    for (uint32_t k = 0; k < g->ncolliders; k++) {
        if (groom_collider_contains(&g->colliders[k], p)) {
            core_vec3 out = groom_collider_outward(&g->colliders[k], prev);
            return core_v3_add(prev, core_v3_scale(out, c->seg));
        }
    }
    return p;
}

/* Rotates unit d toward unit f by at most max_angle radians (about side when they are opposite). */
static core_vec3 turn_toward(core_vec3 d, core_vec3 f, core_vec3 side, float max_angle)
{
    float cosang = core_v3_dot(d, f);
    float angle = acosf(cosang > 1.0f ? 1.0f : cosang < -1.0f ? -1.0f : cosang);
    if (angle <= max_angle) return f;
    core_vec3 axis = core_v3_cross(d, f);
    axis = core_v3_len(axis) > 1e-6f ? core_v3_norm(axis) : side;
    return core_v3_norm(core_q_rotate(core_q_axis_angle(axis, max_angle), d));
}

static void grow_strand(const strand_ctx *c, float *pos)
{
    uint32_t nv = c->g->nverts;
    core_vec3 prev = c->root;
    memcpy(pos, &prev, sizeof(float) * 3);
    core_vec3 dir = c->normal;
    core_vec3 n = core_v3_cross(dir, core_v3(0.0f, 1.0f, 0.0f));
    n = core_v3_len(n) > 1e-3f ? core_v3_norm(n) : core_v3(1.0f, 0.0f, 0.0f);
    float max_turn = c->seg / COMB_RADIUS;
    for (uint32_t i = 1; i < nv; i++) {
        float s = ((float)i - 0.5f) * c->seg;
        core_vec3 step = core_v3_norm(style_dir(c, dir, n, s));
        core_vec3 want = core_v3_add(prev, core_v3_scale(step, c->seg));
        core_vec3 p = drape(c, prev, want);
        core_vec3 push = core_v3_sub(p, want);
        if (core_v3_len(push) > 1e-6f) { /* a collider deflected the strand: stop heading into it */
            core_vec3 out = core_v3_norm(push);
            float into = core_v3_dot(dir, out);
            if (into < 0.0f) dir = core_v3_norm(core_v3_sub(dir, core_v3_scale(out, into)));
        }
        pos[3 * i + 0] = p.x;
        pos[3 * i + 1] = p.y;
        pos[3 * i + 2] = p.z;
        prev = p;
        /* comb toward the fall direction, then carry the side vector along (parallel transport) */
        dir = turn_toward(dir, c->fall, n, max_turn);
        core_vec3 t = core_v3_sub(n, core_v3_scale(dir, core_v3_dot(n, dir)));
        if (core_v3_len(t) > 1e-4f) n = core_v3_norm(t);
        else n = core_v3_norm(core_v3_cross(dir, core_v3(1.0f, 0.0f, 0.0f)));
    }
}

core_status groom_procedural(const groom_desc *d, core_groom *out, core_err *err)
{
    groom_desc z;
    memset(&z, 0, sizeof z);
    if (!d) d = &z;
    uint32_t ns = d->nstrands ? d->nstrands : GROOM_DEFAULT_STRANDS;
    uint32_t nv = d->nverts ? d->nverts : GROOM_DEFAULT_VERTS;
    float length = d->length != 0.0f ? d->length : GROOM_DEFAULT_LENGTH;
    memset(out, 0, sizeof *out);
    if ((unsigned)d->style > GROOM_CURLY) return core_fail(err, CORE_EINVAL, "unknown groom style %d", (int)d->style);
    if (ns > GROOM_MAX_STRANDS)
        return core_fail(err, CORE_EINVAL, "groom strands %u out of range [1, %u]", ns, GROOM_MAX_STRANDS);
    if (nv < 2 || nv > GROOM_MAX_VERTS)
        return core_fail(err, CORE_EINVAL, "groom vertices per strand %u out of range [2, %u]", nv, GROOM_MAX_VERTS);
    if ((uint64_t)ns * nv > GROOM_MAX_TOTAL)
        return core_fail(err, CORE_EINVAL, "groom of %u x %u vertices exceeds the %u vertex limit", ns, nv, GROOM_MAX_TOTAL);
    if (!isfinite(length) || !(length > 0.0f) || length > 2.0f)
        return core_fail(err, CORE_EINVAL, "groom strand length %g m out of range (0, 2]", (double)length);
    core_status st = core_groom_alloc(out, ns, nv, err);
    if (st != CORE_OK) return st;
    groom_default_colliders(out);

    groom_rng rng = { d->seed ? d->seed : GROOM_DEFAULT_SEED };
    strand_ctx c = { .g = out, .style = d->style };
    for (uint32_t s = 0; s < ns; s++) {
        pick_root(&rng, &c);
        float ls = length * (1.0f + LENGTH_JITTER * (2.0f * groom_rng_float(&rng) - 1.0f));
        c.seg = ls / (float)(nv - 1);
        c.phase = 2.0f * PI_F * groom_rng_float(&rng);
        grow_strand(&c, out->pos + (size_t)s * nv * 3);
    }
    return CORE_OK;
}

core_status groom_style_parse(const char *name, groom_style *out, core_err *err)
{
    static const groom_style all[] = { GROOM_STRAIGHT, GROOM_WAVY, GROOM_CURLY };
    for (size_t i = 0; name && i < sizeof all / sizeof all[0]; i++) {
        if (strcmp(name, groom_style_name(all[i])) == 0) {
            *out = all[i];
            return CORE_OK;
        }
    }
    return core_fail(err, CORE_EINVAL, "unknown groom style '%s' (expected straight, wavy or curly)", name ? name : "(null)");
}

const char *groom_style_name(groom_style s)
{
    switch (s) {
    case GROOM_STRAIGHT: return "straight";
    case GROOM_WAVY: return "wavy";
    case GROOM_CURLY: return "curly";
    }
    return "unknown";
}
