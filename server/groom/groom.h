/* groom: procedural grooms, .tfx / .hair loaders, resampling, character colliders, collision
 * meshes (.obj / .tfxmesh) and their signed distance fields. */
#ifndef GROOM_GROOM_H
#define GROOM_GROOM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../core/core.h"
#include "../core/groom_types.h"
#include "../core/sdf.h"

/* Limits shared by the procedural generator and the loaders. */
#define GROOM_MAX_STRANDS (1u << 22)      /* strands per groom */
#define GROOM_MAX_VERTS (1u << 12)        /* vertices per strand (output and .tfx input) */
#define GROOM_MAX_TOTAL (1u << 26)        /* vertices per groom (output and file input) */
#define GROOM_MAX_FILE_BYTES (512u << 20) /* groom_load_file refuses larger files */

#define GROOM_DEFAULT_STRANDS 4096u
#define GROOM_DEFAULT_VERTS 32u
#define GROOM_DEFAULT_LENGTH 0.25f         /* metres */
#define GROOM_DEFAULT_SEED 0x5eed5eed2015ull

/* The default head ellipsoid (head frame, metres): centred at the origin, x = half width,
 * y = half height (up), z = half depth (+z = face). */
#define GROOM_HEAD_RX 0.08f
#define GROOM_HEAD_RY 0.10f
#define GROOM_HEAD_RZ 0.095f

typedef enum groom_style { GROOM_STRAIGHT = 0, GROOM_WAVY, GROOM_CURLY } groom_style;

/* Procedural groom settings; zero means default for every field. */
typedef struct groom_desc {
    groom_style style;
    uint32_t nstrands; /* 0 = 4096, at most GROOM_MAX_STRANDS */
    uint32_t nverts;   /* 0 = 32, 2..GROOM_MAX_VERTS */
    uint64_t seed;     /* 0 = GROOM_DEFAULT_SEED */
    float length;      /* mean strand length in metres, 0 = 0.25; finite, (0, 2] */
} groom_desc;

/* Generates a procedural groom: roots 1 mm outside the scalp (upper and back part, not the
 * face) of the default head ellipsoid, strands growing along the surface normal and then
 * combed downward, draped outside every default collider (each new vertex is projected out of
 * the colliders with a 1 mm margin, then its segment renormalised). Per-strand length varies
 * by +-8% around d->length; inside a strand every segment has the same length. wavy adds a
 * planar wave (3.5 waves per 0.25 m), curly a helix of 1 cm radius. Bitwise deterministic
 * from the seed for a given build. out receives the default colliders
 * (groom_default_colliders). d may be NULL (all defaults). out must be zeroed or freed; the
 * caller owns it (core_groom_free). Pure, any thread. */
core_status groom_procedural(const groom_desc *d, core_groom *out, core_err *err);

/* Parses "straight" | "wavy" | "curly" (exact, lowercase). CORE_EINVAL otherwise. Pure. */
core_status groom_style_parse(const char *name, groom_style *out, core_err *err);

/* Name of a style ("straight", ...; "unknown" for out-of-range values); static storage. */
const char *groom_style_name(groom_style s);

/* Loads a TressFX .tfx file image (layout in shared/assets/README.md) of size bytes.
 * nverts: target vertex count per strand (0 = keep the file's), 2..GROOM_MAX_VERTS.
 * Every strand is resampled arc-length uniform (groom_resample_polyline); positions are
 * taken as they are (the file's frame and units); the w component is ignored. Colliders are
 * left empty (ncolliders = 0): call groom_fit_colliders if needed. A malformed image is
 * refused with CORE_EFORMAT and a message naming the problem and where (byte offset,
 * strand). Never reads outside data[0, size). out must be zeroed or freed; the caller owns
 * it. Pure, any thread. */
core_status groom_load_tfx(const void *data, size_t size, uint32_t nverts, core_groom *out, core_err *err);

/* Loads a Cem Yuksel .hair file image (128-byte "HAIR" header, then the arrays its flags name:
 * segments, points, thickness, transparency, colours) of size bytes; the file
 * size must equal what the header implies. nverts: target vertex count per strand, or 0 =
 * keep the file's count when every strand has the same number of points (and at most
 * GROOM_MAX_VERTS), else 32. Strands are resampled arc-length uniform; positions are taken
 * as they are (no unit or axis conversion); thickness, transparency and colour arrays are
 * skipped. Colliders are left empty. Errors, bounds and ownership as groom_load_tfx. */
core_status groom_load_hair(const void *data, size_t size, uint32_t nverts, core_groom *out, core_err *err);

/* Reads the file at path (at most GROOM_MAX_FILE_BYTES) and loads it by extension (.tfx or
 * .hair, case-insensitive, with the loaders above; .hairmesh.obj: a layered hair mesh,
 * groom_hairmesh_load_obj, with GROOM_DEFAULT_STRANDS or a little more guides traced through it,
 * whole strands per face, nverts vertices each, 0 = GROOM_DEFAULT_VERTS), then fits colliders under its roots
 * (groom_fit_colliders). CORE_EIO when the file cannot be read, CORE_EINVAL for an unknown
 * extension, the loader's error otherwise. out must be zeroed or freed; the caller owns it.
 * Blocking file I/O, any thread. */
core_status groom_load_file(const char *path, uint32_t nverts, core_groom *out, core_err *err);

/* Resamples the polyline in[0 .. 3*n_in) (n_in >= 2 points, finite) to n_out >= 2 points
 * spaced uniformly along its arc length, written to out[0 .. 3*n_out) (must not overlap in).
 * The end points are copied exactly. CORE_EINVAL for bad counts or a polyline of zero
 * length. Pure, any thread. */
core_status groom_resample_polyline(const float *in, uint32_t n_in, float *out, uint32_t n_out, core_err *err);

/* Replaces g's colliders by the default character: the head ellipsoid (GROOM_HEAD_R*, at the
 * origin), a neck capsule and two shoulder capsules. Pure. */
void groom_default_colliders(core_groom *g);

/* Replaces g's colliders by one head ellipsoid (CORE_COLLIDER_ELLIPSOID, axis-aligned in the
 * head frame) fitted to the roots alone (vertex 0 of each strand, taken to lie on the scalp;
 * the strands' directions are not used, so hanging hair fits as well as hair growing out).
 * The fit: an algebraic sphere fit in the space scaled by the default head proportions
 * (GROOM_HEAD_RX : RY : RZ) as the start, then a least-squares fit of centre and semi-axes to
 * the roots' radial residuals, regularised toward those proportions and (weakly) toward the
 * size the roots' x/z spread implies, semi-axes kept in [0.05, 0.2] m. When the roots do not
 * determine it (fewer than 4, collinear, coplanar) or the centre comes out above the roots'
 * centroid (by more than 1 cm), the prior is used instead: the default head scaled to the
 * roots' x/z spread, centred over them, its top at the highest root. Finally the ellipsoid is
 * shrunk about its centre so that every root lies outside it by 1 mm (in the sense of
 * groom_collider_push_out: outside the ellipsoid whose semi-axes are 1 mm longer); roots never
 * start inside. Non-finite roots are ignored. Leaves g without colliders when no root is
 * finite or a semi-axis would be under 5 mm; never emits a non-finite collider. Needs
 * g->nverts >= 2. Pure (allocates a scratch copy of the roots; on allocation failure g is
 * left without colliders). Any thread. */
void groom_fit_colliders(core_groom *g);

/* ---- collision meshes and signed distance fields ------------------------------------- */

#define GROOM_MESH_MAX_VERTS (1u << 20)       /* vertices per collision mesh */
#define GROOM_MESH_MAX_TRIS (1u << 21)        /* triangles per collision mesh (after fan triangulation) */
#define GROOM_MESH_MAX_FILE_BYTES (256u << 20) /* groom_mesh_load_file refuses larger files */
#define GROOM_MESH_MAX_LINE 4096u              /* bytes per text line, newline excluded */
#define GROOM_MESH_MAX_COORD 100.0f            /* |coordinate| limit, metres */

/* Checks that m is a valid collision mesh: 1..GROOM_MESH_MAX_VERTS vertices, finite
 * coordinates within GROOM_MESH_MAX_COORD, 1..GROOM_MESH_MAX_TRIS triangles with indices in
 * range and no repeated index, closed and manifold with a consistent orientation (every
 * undirected edge used by exactly two triangles, once in each direction) and a positive
 * enclosed volume (counter-clockwise seen from outside). CORE_EFORMAT with a message naming the
 * triangles, vertices or edge at fault; CORE_ENOMEM. Pure, any thread. */
core_status groom_mesh_check(const core_mesh *m, core_err *err);

/* Loads a Wavefront .obj image of size bytes (not NUL-terminated; never read outside
 * data[0, size)). Reads `v x y z [...]` and `f` lines (3 or more vertices, fan-triangulated;
 * `i`, `i/t`, `i//n`, `i/t/n` forms; negative indices count back from the last vertex read);
 * comments (#) and every other line type are ignored. A face may only use vertices defined
 * above it. The result must pass groom_mesh_check. A malformed image is refused with
 * CORE_EFORMAT and a message naming the line (or triangles/edge). out is overwritten; the
 * caller owns it (core_mesh_free). Pure, any thread. */
core_status groom_mesh_load_obj(const void *data, size_t size, core_mesh *out, core_err *err);

/* Loads a TressFX .tfxmesh image (text, layout in shared/assets/README.md) of size bytes:
 * `#` comments and blank lines skipped, an optional `numOfBones N` section (N lines, ignored),
 * `numOfVertices N` with N lines `i x y z ...` (i = 0..N-1 in order; only x y z are used),
 * `numOfTriangles N` with N lines `i v0 v1 v2`; nothing but comments may follow. Bounds,
 * validation, errors and ownership as groom_mesh_load_obj. Pure, any thread. */
core_status groom_mesh_load_tfxmesh(const void *data, size_t size, core_mesh *out, core_err *err);

/* Reads the file at path (at most GROOM_MESH_MAX_FILE_BYTES) and loads it by extension (.obj or
 * .tfxmesh, case-insensitive). CORE_EIO when it cannot be read, CORE_EINVAL for an unknown
 * extension or a file too large, the loader's error (prefixed by the path) otherwise. out is
 * overwritten; the caller owns it. Blocking file I/O, any thread. */
core_status groom_mesh_load_file(const char *path, core_mesh *out, core_err *err);

#define GROOM_SDF_DEFAULT_CELL 0.002f         /* metres */
#define GROOM_SDF_DEFAULT_MAX_CELLS (16u << 20) /* samples */

/* Signed distance field settings; zero means default for every field. */
typedef struct groom_sdf_desc {
    float cell;         /* sample spacing, m; 0 = GROOM_SDF_DEFAULT_CELL; else finite, > 0 */
    core_vec3 lo, hi;   /* region, mesh frame; both all-zero = the mesh bounds grown by 4 cells,
                           else lo < hi on every axis and the region is grown by 2 cells */
    uint32_t max_cells; /* 0 = GROOM_SDF_DEFAULT_MAX_CELLS (at least 8 are used); when the region
                           needs more samples the cell grows until it fits */
} groom_sdf_desc;

/* Builds the signed distance grid of the closed mesh m (checked with groom_mesh_check) over
 * the region of d (NULL = defaults): out->cell >= d->cell, out->origin = region low corner,
 * dims cover the region. Samples within 3 cells of the surface hold the exact distance to the
 * nearest triangle (float precision); farther ones the distance to a surface point found by
 * propagating nearest points through the grid (never below the true distance to the surface
 * parts within 3 cells of the grid; typically exact to a fraction of a cell). The sign is
 * exact everywhere (inside = winding number of the mesh around the sample is nonzero, counted
 * along +x grid lines with exact, consistently tie-broken crossing tests). Transient memory
 * about 18 bytes per sample. out is overwritten; the caller owns it (core_sdf_free).
 * CORE_EINVAL for a bad desc, the check's error for a bad mesh, CORE_ENOMEM. Pure, any thread. */
core_status groom_sdf_build(const core_mesh *m, const groom_sdf_desc *d, core_sdf *out, core_err *err);

#define GROOM_COLLIDER_REACH_PAD 0.02f /* m beyond the longest strand around the roots */
#define GROOM_COLLIDER_MESH_PAD 0.01f  /* m around the mesh bounds */
#define GROOM_COLLIDER_MAX_CELLS (8u << 20) /* samples of a collision mesh's grid (the cell grows to fit) */

/* The box (head frame) where the SDF of collision mesh m is needed for groom g: the roots'
 * bounding box grown by the longest strand (rest arc length) + GROOM_COLLIDER_REACH_PAD,
 * intersected with m's bounds grown by GROOM_COLLIDER_MESH_PAD. False (lo, hi unset) when
 * they do not overlap or g has no finite root. Pure, any thread. */
bool groom_collider_region(const core_groom *g, const core_mesh *m, core_vec3 *lo, core_vec3 *hi);

/* ---- hair meshes (layered prisms over the scalp; core/hairmesh_types.h) --------------------- */

#define GROOM_HAIRMESH_DEFAULT_PATCHES 3u /* patches along each side of the scalp region */
#define GROOM_HAIRMESH_DEFAULT_GRID 2u    /* quads along each side of a patch */
#define GROOM_HAIRMESH_DEFAULT_LAYERS 9u
#define GROOM_HAIRMESH_MAX_GRID 256u

/* Procedural hair mesh settings; zero means default for every field. */
typedef struct groom_hairmesh_desc {
    groom_style style;  /* the layers' offsets: straight, wavy (a planar wave of 7 mm, 2 waves
                           per 0.25 m) or curly (a helix of 7 mm radius, 1.5 turns per 0.25 m) */
    uint32_t patches;   /* 0 = GROOM_HAIRMESH_DEFAULT_PATCHES; 1..GROOM_HAIRMESH_MAX_GRID patches per side */
    uint32_t grid;      /* 0 = GROOM_HAIRMESH_DEFAULT_GRID; 1..GROOM_HAIRMESH_MAX_GRID quads per patch side */
    uint32_t nlayers;   /* 0 = GROOM_HAIRMESH_DEFAULT_LAYERS; 2..CORE_HAIRMESH_MAX_LAYERS */
    float length;       /* root-to-tip path length, m; 0 = GROOM_DEFAULT_LENGTH; finite, (0, 2] */
} groom_hairmesh_desc;

/* Generates a hair mesh over the upper and back part of the default head ellipsoid: patches x
 * patches scalp patches (each fills its cell, so neighbours touch), each of (grid + 1)^2
 * columns and grid^2 quads (counter-clockwise seen from outside) 1 mm outside the scalp, swept
 * through nlayers - 1 further layers at even steps along the patch centre's path (it grows along
 * the scalp normal, is combed down and back, and keeps 3 mm + 12% of the patch's half size +
 * 6 mm x (layer / (nlayers - 1)) outside the default colliders, so layer 1 lies a few mm off
 * the scalp). Each layer is the root patch with its extent along the comb direction squashed to
 * 12% (a sheet lying on the head), carried by the path's parallel-transported frame (so the
 * faces stay across the path and every prism's corner tetrahedra have a positive volume),
 * narrowed linearly to 80% at the tip, moved by the style's offset (the same for every column at
 * a given path length) and kept 1 mm outside the default colliders. No guides (nguides = 0). Deterministic. out is overwritten; the caller
 * owns it (core_hairmesh_free). CORE_EINVAL for a bad desc. d may be NULL. Pure, any thread. */
core_status groom_hairmesh_procedural(const groom_hairmesh_desc *d, core_hairmesh *out, core_err *err);

/* Fills out with guide strands traced through m (checked with core_hairmesh_validate):
 * per_face >= 1 strands in every face at fixed, well spread coordinates (strand i of a face at
 * u = frac(0.5 + 0.7548777 i), v = frac(0.5 + 0.5698403 i) on a quad, the same pair mapped
 * uniformly onto a triangle: weights of corners 1 and 2 = (sqrt(u) (1 - v), sqrt(u) v)), strand
 * f * per_face + i, each of nverts (2..GROOM_MAX_VERTS) vertices by core_hairmesh_trace at its
 * even layer parameters on m (core_hairmesh_even_params: equal segments at rest).
 * out->hairmesh is a copy of m whose guide arrays record those strands, their parameters
 * included (guide_nverts = nverts; m's own guides are not used). No colliders. Counts past GROOM_MAX_STRANDS / GROOM_MAX_TOTAL: CORE_EINVAL.
 * out must be zeroed or freed; the caller owns it (core_groom_free). Pure, any thread. */
core_status groom_from_hairmesh(const core_hairmesh *m, uint32_t per_face, uint32_t nverts, core_groom *out,
                                core_err *err);

/* Loads a layered hair mesh from a Wavefront .obj image of size bytes (never read outside
 * data[0, size)). The convention (README.md, "Hair meshes"): `v x y z` lines list the layers
 * one after another, the root layer first, every layer with the same number C of vertices in
 * the same column order (vertex l * C + c + 1 is column c of layer l); `f` lines (3 or 4
 * vertices, `i`, `i/t`, `i//n`, `i/t/n` forms, negative indices count back from the last
 * vertex read) are the root layer's faces, counter-clockwise seen from outside the scalp, and
 * use only vertices 1..C; C is the largest vertex index a face uses, the vertex count must be
 * a multiple of it (nlayers = vertices / C >= 2). Comments (#) and other line types are
 * ignored. The result must pass core_hairmesh_validate. A malformed image is refused with
 * CORE_EFORMAT naming the line or face. out is overwritten; the caller owns it. Pure. */
core_status groom_hairmesh_load_obj(const void *data, size_t size, core_hairmesh *out, core_err *err);

/* Writes m in the convention of groom_hairmesh_load_obj (a comment line, the layers' `v` lines,
 * the root faces; 9 significant digits, so the loader reads the same floats back) into a
 * NUL-terminated buffer *out (*len bytes without the NUL); the caller frees it. Guides are not
 * written. CORE_ENOMEM. Pure, any thread. */
core_status groom_hairmesh_write_obj(const core_hairmesh *m, char **out, size_t *len, core_err *err);

#endif
