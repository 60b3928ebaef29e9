/* groom: the procedural hair mesh (scalp patches on the default head swept through layers). */
#include "groom.h"
#include "groom_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Path steps per layer (the comb and the drape act at this finer resolution). */
#define PATH_STEPS 8
#define ROOT_LIFT 0.001f
#define CLEAR_BASE 0.003f /* the path's clearance outside the colliders beyond half the sheet */
#define CLEAR_GROW 0.006f /* and its growth from root to tip */
#define SQUASH 0.12f      /* a patch's extent along its comb direction kept as the sheet's thickness */
#define TAPER 0.2f        /* how much a patch's cross-section narrows from root to tip */

/* The scalp point and outward normal of grid corner (s, t) in [0, 1]^2: s runs over the head
 * from the left side (-x) to the right (+x), t from the hairline in front of the crown over the
 * back. */
static void scalp_point(float s, float t, core_vec3 *p, core_vec3 *n)
{
    float a = (s - 0.5f) * 2.2f, b = -0.35f + t * 1.9f;
    core_vec3 d = core_v3(sinf(a), cosf(a) * cosf(b), -cosf(a) * sinf(b));
    core_vec3 e = core_v3(GROOM_HEAD_RX * d.x, GROOM_HEAD_RY * d.y, GROOM_HEAD_RZ * d.z);
    *n = core_v3_norm(core_v3(e.x / (GROOM_HEAD_RX * GROOM_HEAD_RX), e.y / (GROOM_HEAD_RY * GROOM_HEAD_RY),
                              e.z / (GROOM_HEAD_RZ * GROOM_HEAD_RZ)));
    *p = core_v3_add(e, core_v3_scale(*n, ROOT_LIFT));
}

/* The style's offset at path length sl (m) for a column whose path starts along n: the same for
 * every column, so neighbouring columns keep their spacing. */
static core_vec3 style_offset(groom_style style, float sl)
{
    const float amp = 0.007f, two_pi = 6.2831853f;
    if (style == GROOM_WAVY) return core_v3(amp * sinf(two_pi * 2.0f * sl / 0.25f), 0.0f, 0.0f);
    if (style == GROOM_CURLY) {
        float ph = two_pi * 1.5f * sl / 0.25f;
        return core_v3(amp * sinf(ph), 0.0f, amp * (1.0f - cosf(ph)));
    }
    return core_v3(0.0f, 0.0f, 0.0f);
}

/* Keeps p outside the default colliders grown by margin. */
static core_vec3 drape(const core_groom *body, core_vec3 p, float margin)
{
    for (int pass = 0; pass < 2; pass++)
        for (uint32_t k = 0; k < body->ncolliders; k++) groom_collider_push_out(&body->colliders[k], &p, margin);
    return p;
}

/* The comb direction of grow_path for a path starting along n. */
static core_vec3 comb_of(core_vec3 n) { return core_v3_norm(core_v3(0.3f * n.x, -1.0f, 0.3f * n.z - 0.25f)); }

/* The unit direction in the scalp's tangent plane (normal n) the comb lays a patch's hair along
 * (straight back where the comb is along n). */
static core_vec3 comb_along(core_vec3 n)
{
    core_vec3 c = comb_of(n), a = core_v3_sub(c, core_v3_scale(n, core_v3_dot(c, n)));
    return core_v3_len(a) > 1e-4f ? core_v3_norm(a) : core_v3_norm(core_v3_sub(core_v3(0.0f, 0.0f, -1.0f), core_v3_scale(n, -n.z)));
}

/* The central path of a patch: nl points (PATH_STEPS substeps per layer) that grow along n, are
 * combed down and back, and keep `clear` + the layer's share of CLEAR_GROW outside the default
 * colliders; tangent[l] is the path's direction at point l (n at the root). */
static void grow_path(const core_groom *body, core_vec3 root, core_vec3 n, float length, float clear, uint32_t nl,
                      core_vec3 *point, core_vec3 *tangent)
{
    core_vec3 comb = comb_of(n);
    core_vec3 p = root, dir = n;
    float ds = length / (float)((nl - 1) * PATH_STEPS);
    point[0] = root, tangent[0] = n;
    for (uint32_t l = 1; l < nl; l++) {
        float frac = (float)l / (float)(nl - 1);
        for (int k = 0; k < PATH_STEPS; k++) {
            dir = core_v3_norm(core_v3_add(dir, core_v3_scale(comb, 0.35f)));
            core_vec3 q = drape(body, core_v3_add(p, core_v3_scale(dir, ds)), clear + CLEAR_GROW * frac);
            core_vec3 step = core_v3_sub(q, p);
            float sl = core_v3_len(step);
            if (sl > 0.0f) dir = core_v3_scale(step, 1.0f / sl);
            p = q;
        }
        point[l] = p, tangent[l] = dir;
    }
}

/* The minimal rotation taking unit a to unit b (identity when they are equal; about any axis
 * normal to a when they are opposite). */
static core_quat rotation_between(core_vec3 a, core_vec3 b)
{
    core_vec3 c = core_v3_cross(a, b);
    float d = core_v3_dot(a, b);
    if (d < -0.9999f) {
        core_vec3 axis = core_v3_norm(core_v3_cross(a, fabsf(a.x) < 0.9f ? core_v3(1.0f, 0.0f, 0.0f) : core_v3(0.0f, 1.0f, 0.0f)));
        return core_q_axis_angle(axis, 3.14159265f);
    }
    core_quat q = { c.x, c.y, c.z, 1.0f + d };
    return core_q_norm(q);
}

core_status groom_hairmesh_procedural(const groom_hairmesh_desc *d, core_hairmesh *out, core_err *err)
{
    static const groom_hairmesh_desc zero;
    memset(out, 0, sizeof *out);
    if (!d) d = &zero;
    uint32_t np = d->patches ? d->patches : GROOM_HAIRMESH_DEFAULT_PATCHES;
    uint32_t grid = d->grid ? d->grid : GROOM_HAIRMESH_DEFAULT_GRID;
    uint32_t nl = d->nlayers ? d->nlayers : GROOM_HAIRMESH_DEFAULT_LAYERS;
    float length = d->length != 0.0f ? d->length : GROOM_DEFAULT_LENGTH;
    if (np > GROOM_HAIRMESH_MAX_GRID || grid > GROOM_HAIRMESH_MAX_GRID || (uint64_t)np * np * (grid + 1) * (grid + 1) * nl > CORE_HAIRMESH_MAX_VERTS)
        return core_fail(err, CORE_EINVAL, "hair mesh of %u x %u patches of %u x %u quads is outside the limits (%u per side, %u vertices)",
                         np, np, grid, grid, GROOM_HAIRMESH_MAX_GRID, CORE_HAIRMESH_MAX_VERTS);
    if (nl < 2 || nl > CORE_HAIRMESH_MAX_LAYERS)
        return core_fail(err, CORE_EINVAL, "hair mesh layers %u is outside 2..%u", nl, CORE_HAIRMESH_MAX_LAYERS);
    if (!(length > 0.0f && length <= 2.0f))
        return core_fail(err, CORE_EINVAL, "hair mesh length %g m is outside (0, 2]", (double)length);
    if ((unsigned)d->style > GROOM_CURLY) return core_fail(err, CORE_EINVAL, "unknown hair mesh style %d", (int)d->style);
    const uint32_t side = grid + 1, per = side * side;
    core_status st = core_hairmesh_alloc(out, np * np * per, nl, np * np * grid * grid, 0, 0, err);
    if (st != CORE_OK) return st;
    core_vec3 *point = malloc(2 * (size_t)nl * sizeof *point);
    if (!point) {
        core_hairmesh_free(out);
        return core_fail(err, CORE_ENOMEM, "out of memory for a hair mesh path");
    }
    core_vec3 *tangent = point + nl;
    core_groom body;
    memset(&body, 0, sizeof body);
    groom_default_colliders(&body);
    const float cell = 1.0f / (float)np, span = cell;
    for (uint32_t pj = 0; pj < np; pj++)
        for (uint32_t pi = 0; pi < np; pi++) {
            const uint32_t patch = pj * np + pi, c0 = patch * per;
            const float s0 = ((float)pi + 0.5f) * cell, t0 = ((float)pj + 0.5f) * cell;
            core_vec3 centre, n;
            scalp_point(s0, t0, &centre, &n);
            core_vec3 corner, cn;
            scalp_point(s0 - 0.5f * span, t0 - 0.5f * span, &corner, &cn);
            const float half = core_v3_len(core_v3_sub(corner, centre));
            grow_path(&body, centre, n, length, CLEAR_BASE + SQUASH * half, nl, point, tangent);
            const core_vec3 along = comb_along(n);
            core_quat q = core_q_identity();
            for (uint32_t l = 0; l < nl; l++) {
                if (l > 0) q = core_q_norm(core_q_mul(rotation_between(tangent[l - 1], tangent[l]), q));
                const float frac = (float)l / (float)(nl - 1), taper = 1.0f - TAPER * frac;
                const core_vec3 o = style_offset(d->style, length * frac);
                for (uint32_t j = 0; j < side; j++)
                    for (uint32_t i = 0; i < side; i++) {
                        core_vec3 root, rn;
                        scalp_point(s0 + span * ((float)i / (float)grid - 0.5f), t0 + span * ((float)j / (float)grid - 0.5f), &root, &rn);
                        core_vec3 p = root;
                        if (l > 0) {
                            core_vec3 rel = core_v3_sub(root, centre);
                            rel = core_v3_sub(rel, core_v3_scale(along, (1.0f - SQUASH) * core_v3_dot(rel, along)));
                            core_vec3 off = core_q_rotate(q, rel);
                            p = drape(&body, core_v3_add(core_v3_add(point[l], core_v3_scale(off, taper)), o), ROOT_LIFT);
                        }
                        memcpy(out->pos + 3 * ((size_t)(c0 + j * side + i) * nl + l), &p, 3 * sizeof(float));
                    }
            }
            for (uint32_t j = 0; j < grid; j++)
                for (uint32_t i = 0; i < grid; i++) {
                    uint32_t *f = out->faces + 4 * (size_t)(patch * grid * grid + j * grid + i);
                    f[0] = c0 + j * side + i, f[1] = c0 + j * side + i + 1;
                    f[2] = c0 + (j + 1) * side + i + 1, f[3] = c0 + (j + 1) * side + i;
                }
        }
    free(point);
    return CORE_OK;
}
