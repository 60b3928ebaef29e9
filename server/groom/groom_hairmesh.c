/* groom: the procedural hair mesh (a scalp patch on the default head extruded through layers). */
#include "groom.h"
#include "groom_internal.h"

#include <math.h>
#include <string.h>

/* Path steps per layer (the comb and the drape act at this finer resolution). */
#define PATH_STEPS 8
#define ROOT_LIFT 0.001f
#define CLEAR_BASE 0.005f
#define CLEAR_GROW 0.01f

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
    const float amp = 0.01f, two_pi = 6.2831853f;
    if (style == GROOM_WAVY) return core_v3(amp * sinf(two_pi * 3.5f * sl / 0.25f), 0.0f, 0.0f);
    if (style == GROOM_CURLY) {
        float ph = two_pi * 4.0f * sl / 0.25f;
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

/* One column's layer positions (nl of them) into out (column-major run of 3 * nl floats). */
static void grow_column(const core_groom *body, groom_style style, core_vec3 root, core_vec3 n, float length,
                        uint32_t nl, float *out)
{
    core_vec3 comb = core_v3_norm(core_v3(0.3f * n.x, -1.0f, 0.3f * n.z - 0.25f));
    core_vec3 p = root, dir = n;
    float ds = length / (float)((nl - 1) * PATH_STEPS);
    memcpy(out, &root, 3 * sizeof(float));
    for (uint32_t l = 1; l < nl; l++) {
        float frac = (float)l / (float)(nl - 1);
        for (int k = 0; k < PATH_STEPS; k++) {
            dir = core_v3_norm(core_v3_add(dir, core_v3_scale(comb, 0.35f)));
            core_vec3 q = core_v3_add(p, core_v3_scale(dir, ds));
            q = drape(body, q, CLEAR_BASE + CLEAR_GROW * frac);
            core_vec3 step = core_v3_sub(q, p);
            float sl = core_v3_len(step);
            if (sl > 0.0f) dir = core_v3_scale(step, 1.0f / sl);
            p = q;
        }
        core_vec3 o = core_v3_add(p, style_offset(style, length * frac));
        memcpy(out + 3 * l, &o, 3 * sizeof(float));
    }
}

core_status groom_hairmesh_procedural(const groom_hairmesh_desc *d, core_hairmesh *out, core_err *err)
{
    static const groom_hairmesh_desc zero;
    memset(out, 0, sizeof *out);
    if (!d) d = &zero;
    uint32_t grid = d->grid ? d->grid : GROOM_HAIRMESH_DEFAULT_GRID;
    uint32_t nl = d->nlayers ? d->nlayers : GROOM_HAIRMESH_DEFAULT_LAYERS;
    float length = d->length != 0.0f ? d->length : GROOM_DEFAULT_LENGTH;
    if (grid > GROOM_HAIRMESH_MAX_GRID)
        return core_fail(err, CORE_EINVAL, "hair mesh grid %u is outside 1..%u", grid, GROOM_HAIRMESH_MAX_GRID);
    if (nl < 2 || nl > CORE_HAIRMESH_MAX_LAYERS)
        return core_fail(err, CORE_EINVAL, "hair mesh layers %u is outside 2..%u", nl, CORE_HAIRMESH_MAX_LAYERS);
    if (!(length > 0.0f && length <= 2.0f))
        return core_fail(err, CORE_EINVAL, "hair mesh length %g m is outside (0, 2]", (double)length);
    if ((unsigned)d->style > GROOM_CURLY) return core_fail(err, CORE_EINVAL, "unknown hair mesh style %d", (int)d->style);
    uint32_t side = grid + 1;
    core_status st = core_hairmesh_alloc(out, side * side, nl, grid * grid, 0, err);
    if (st != CORE_OK) return st;
    core_groom body;
    memset(&body, 0, sizeof body);
    groom_default_colliders(&body);
    for (uint32_t j = 0; j < side; j++)
        for (uint32_t i = 0; i < side; i++) {
            core_vec3 p, n;
            scalp_point((float)i / (float)grid, (float)j / (float)grid, &p, &n);
            uint32_t c = j * side + i;
            grow_column(&body, d->style, p, n, length, nl, out->pos + 3 * (size_t)c * nl);
        }
    for (uint32_t j = 0; j < grid; j++)
        for (uint32_t i = 0; i < grid; i++) {
            uint32_t *f = out->faces + 4 * (size_t)(j * grid + i);
            f[0] = j * side + i, f[1] = j * side + i + 1, f[2] = (j + 1) * side + i + 1, f[3] = (j + 1) * side + i;
        }
    return CORE_OK;
}
