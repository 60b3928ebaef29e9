/* core: the hair mesh (layered prisms over the scalp) and the rule that traces strands through it. */
#ifndef CORE_HAIRMESH_TYPES_H
#define CORE_HAIRMESH_TYPES_H

#include <stdint.h>

#include "core.h"

#define CORE_HAIRMESH_NONE 0xffffffffu

/* Limits every loader, generator and solver of hair meshes keeps to. */
#define CORE_HAIRMESH_MAX_VERTS (1u << 20) /* ncols * nlayers */
#define CORE_HAIRMESH_MAX_LAYERS 1024u
#define CORE_HAIRMESH_MAX_FACES (1u << 20)
#define CORE_HAIRMESH_MAX_GUIDES (1u << 22)
#define CORE_HAIRMESH_MAX_GUIDE_VERTS (1u << 26) /* nguides * guide_nverts */
#define CORE_HAIRMESH_MAX_COORD 100.0f     /* |coordinate| limit, metres */

/* A hair mesh (Yuksel et al. 2009; the 2016 simulation paper; the thesis 3.1): a root layer of
 * faces on the scalp extruded through nlayers - 1 further layers. Each root-layer vertex and its
 * copies in the later layers form a column; face f of layer l and face f of layer l + 1 bound
 * prism (f, l). Head frame, metres, y up. The mesh owns its arrays (core_hairmesh_free).
 *
 * Tracing rule (C: core_hairmesh_trace; the viewer's vertex shader does the same): the guide
 * point of a strand at layer l is P_l = sum_k w_k * corner_k(layer l) with the weights of its
 * (u, v): on a quad w = ((1-u)(1-v), u(1-v), uv, (1-u)v) for corners 0..3, on a triangle
 * w = (1-u-v, u, v) for corners 0..2. The strand's curve is the polyline P_0 .. P_{nlayers-1}:
 * layer parameter t in [0, nlayers - 1] is the point P_l + a (P_{l+1} - P_l) with
 * l = min(floor(t), nlayers - 2), a = t - l (computed in float). A strand of nverts vertices puts
 * vertex i at its layer parameter t_i, one table per strand computed once on the REST positions
 * (core_hairmesh_even_params) and kept when the mesh deforms, so that at rest every segment has
 * the same length whatever the layer spacing. Even parameters (web/hairmesh.js evenParams is the
 * same rule): t_0 = 0, t_{nverts-1} = nlayers - 1, and consecutive rest vertices at one straight
 * distance d: from t_i, t_{i+1} is the first parameter past t_i whose point lies at distance d
 * from vertex i (solved exactly on each polyline segment); d is found by 64 bisection steps on
 * [0, rest polyline length / (nverts - 1)] (a d whose walk of nverts - 1 steps reaches past the
 * tip is too long), the walk of the final lower bound gives t_1 .. t_{nverts-2}. Where that
 * walk's last step (from vertex nverts - 2 to the tip-layer point) differs from d by more than
 * 1e-4 d (a curve folding back on itself, where no even distance exists), t_1 .. t_{nverts-2}
 * are at even arc length along the polyline instead. All of it in double from the float
 * positions and float weights; the table is stored in float. A strand of zero rest length gets
 * t_i = i (nlayers - 1) / (nverts - 1). So vertex 0 is the root-layer point and vertex
 * nverts - 1 the tip-layer point. */
typedef struct core_hairmesh {
    uint32_t ncols;     /* vertices per layer */
    uint32_t nlayers;   /* layers including the root layer, >= 2 */
    float *pos;         /* column-major: layer l of column c at pos[3 * (c * nlayers + l) + {0,1,2}] */
    uint32_t nfaces;    /* faces per layer */
    uint32_t *faces;    /* 4 column indices per face, counter-clockwise seen from outside the
                           scalp; a triangle has faces[4 * f + 3] == CORE_HAIRMESH_NONE */
    uint32_t nguides;   /* strands traced through the mesh (0 = none recorded) */
    uint32_t guide_nverts; /* vertices of every traced strand (0 when nguides is 0) */
    uint32_t *guide_face; /* per traced strand: its face */
    float *guide_uv;      /* per traced strand: 2 coordinates in the face: bilinear (u, v) on a quad
                             (corners 0,1,2,3 at (0,0),(1,0),(1,1),(0,1)); barycentric weights of
                             corners 1 and 2 on a triangle (corner 0 gets 1 - u - v) */
    float *guide_t;       /* per traced strand: its guide_nverts layer parameters (the even parameters
                             of the rest mesh, core_hairmesh_even_params), strand s at
                             guide_t[s * guide_nverts] */
} core_hairmesh;

/* Allocates a zeroed mesh of ncols x nlayers vertices, nfaces faces and nguides guides of
 * guide_nverts vertices each (guide arrays NULL and guide_nverts 0 when nguides is 0). Counts
 * within the limits above, ncols >= 3, nlayers >= 2, nfaces >= 1, guide_nverts >= 2 when there
 * are guides (nguides x guide_nverts <= CORE_HAIRMESH_MAX_GUIDE_VERTS); CORE_EINVAL otherwise,
 * CORE_ENOMEM. m is overwritten; the caller owns the result (core_hairmesh_free). Any thread. */
core_status core_hairmesh_alloc(core_hairmesh *m, uint32_t ncols, uint32_t nlayers, uint32_t nfaces,
                                uint32_t nguides, uint32_t guide_nverts, core_err *err);

/* Frees m's arrays and zeroes it; safe on a zeroed or already freed mesh. Any thread. */
void core_hairmesh_free(core_hairmesh *m);

/* Deep copy of src into dst (dst is overwritten, not freed; on failure it is left zeroed).
 * The caller owns dst. Any thread. */
core_status core_hairmesh_copy(core_hairmesh *dst, const core_hairmesh *src, core_err *err);

/* Checks m: counts within the limits, finite coordinates within CORE_HAIRMESH_MAX_COORD, every
 * face with 3 or 4 distinct column indices in range (a triangle's 4th is CORE_HAIRMESH_NONE),
 * every column used by a face, no layer edge shared by more than two faces, guide faces in range
 * and guide coordinates finite and inside their face (quad: u, v in [0, 1]; triangle: u, v >= 0,
 * u + v <= 1; 1e-5 slack), guide_nverts >= 2 with guides, every guide's layer parameters
 * non-decreasing in [0, nlayers - 1]. CORE_EFORMAT naming the face, column or guide at fault.
 * Pure. */
core_status core_hairmesh_validate(const core_hairmesh *m, core_err *err);

/* The corner weights of (u, v) in a face of ncorners (3 or 4) corners (the rule above). Pure. */
void core_hairmesh_weights(uint32_t ncorners, float u, float v, float w[4]);

/* The even layer parameters (the rule above) of a strand of nverts >= 2 vertices at (u, v) in m's
 * face `face`, through the rest positions pos (column-major as in core_hairmesh; normally
 * m->pos), into t[nverts]. Pure. */
void core_hairmesh_even_params(const core_hairmesh *m, const float *pos, uint32_t face, float u, float v,
                               uint32_t nverts, float *t);

/* Traces one strand of nverts >= 2 vertices through the layer positions pos (column-major as
 * in core_hairmesh, ncols x nlayers) of m's face `face` at (u, v) into out[3 * nverts], vertex i
 * at layer parameter t[i] (in [0, nlayers - 1]; the strand's even parameters, the rule above).
 * pos may be m->pos or a deformed copy of it (a solver's state). Pure. */
void core_hairmesh_trace(const core_hairmesh *m, const float *pos, uint32_t face, float u, float v,
                         uint32_t nverts, const float *t, float *out);

#endif
