/* core: the groom (guide strands + colliders) handed from groom loaders to solvers. */
#ifndef CORE_GROOM_TYPES_H
#define CORE_GROOM_TYPES_H

#include <stdint.h>

#include "core.h"
#include "hairmesh_types.h"
#include "math3.h"
#include "sdf.h"

typedef enum core_collider_kind {
    CORE_COLLIDER_SPHERE = 0,   /* center a, radius */
    CORE_COLLIDER_CAPSULE = 1,  /* segment a-b, radius */
    CORE_COLLIDER_ELLIPSOID = 2 /* center a, semi-axes radii along the axes of rot */
} core_collider_kind;

/* A collider in the head's local frame; it moves rigidly with the head transform. */
typedef struct core_collider {
    core_collider_kind kind;
    core_vec3 a, b;     /* centre (sphere, ellipsoid) or segment ends (capsule) */
    float radius;       /* sphere and capsule */
    core_vec3 radii;    /* ellipsoid semi-axes */
    core_quat rot;      /* ellipsoid orientation */
} core_collider;

#define CORE_MAX_COLLIDERS 32

/* Guide strands in the head's local frame (metres, y up), each with the same number of
 * vertices, arc-length uniform; vertex 0 is the root.
 * pos is strand-major: vertex v of strand s is pos[3 * (s * nverts + v) + {0,1,2}].
 * mesh and sdf are the optional character collision shape (head frame; NULL = none): the
 * closed triangle mesh and its signed distance grid.
 * hairmesh is the optional hair mesh the strands were traced through (core/hairmesh_types.h).
 * The groom owns pos, mesh, sdf and hairmesh; release them with core_groom_free. A groom may be moved
 * by struct assignment only when the source is then zeroed, never copied (core_groom_copy). */
typedef struct core_groom {
    uint32_t nstrands;
    uint32_t nverts;
    float *pos;
    uint32_t ncolliders;
    core_collider colliders[CORE_MAX_COLLIDERS];
    core_mesh *mesh; /* owned, NULL = none */
    core_sdf *sdf;   /* owned, NULL = none */
    core_hairmesh *hairmesh; /* owned, NULL = none: the strands are guides traced through it
                                (guide s = guide_face[s], guide_uv[s]) */
} core_groom;

/* Allocates a zeroed groom of nstrands x nverts (nverts >= 2; no mesh, no sdf, no hair mesh). Caller owns the result and
 * frees it with core_groom_free. Any thread. */
core_status core_groom_alloc(core_groom *g, uint32_t nstrands, uint32_t nverts, core_err *err);

/* Frees g->pos, g->mesh, g->sdf and g->hairmesh and zeroes the struct; safe on a zeroed or already freed
 * groom. Any thread. */
void core_groom_free(core_groom *g);

/* Deep copy of src into dst, mesh, sdf and hairmesh included (dst must be zeroed or freed; on failure
 * it is left zeroed). The caller owns dst. Any thread. */
core_status core_groom_copy(core_groom *dst, const core_groom *src, core_err *err);

#endif
