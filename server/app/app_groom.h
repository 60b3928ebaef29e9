/* app: the live groom as the daemon holds it: the groom, the binary of its per-strand data
 * clients fetch, its collision mesh (distance grid and the binary clients fetch) and its
 * pre-rendered JSON. Loading is pure of threads: whoever
 * fills an app_groom owns it (app_groom_free). */
#ifndef APP_GROOM_H
#define APP_GROOM_H

#include "core/core.h"
#include "core/groom_types.h"
#include "net/net.h"
#include "proto/proto.h"

#define APP_MESH_PATH "/collider.bin" /* where clients GET the collision mesh binary */
#define APP_GROOM_PATH "/groom.bin"   /* where clients GET the groom data binary (rest lengths, roots) */
#define APP_HAIRMESH_PATH "/hairmesh.bin" /* where clients GET the hair mesh topology binary */

/* The names set_groom's style may take (hello.grooms.styles): the procedural styles, then the
 * same styles as hair meshes ("hairmesh:<style>", as strandcastd --groom takes them). */
#define APP_NSTYLES 6
extern const char *const app_groom_styles[APP_NSTYLES];

typedef struct app_groom {
    core_groom g;             /* g.mesh / g.sdf: the collision mesh and its distance grid, if any */
    char source[PROTO_MAX_NAME + 16];
    uint64_t seed;
    net_buf *groom_bin;       /* proto_groom_bin_write of g: built once, shared by every client */
    char groom_etag[17];
    net_buf *hairmesh_bin;    /* proto_hairmesh_bin_write of g.hairmesh (NULL = none) */
    char hairmesh_etag[17];
    char collider[PROTO_MAX_NAME + 1]; /* the mesh's name ("" = none) */
    net_buf *mesh_bin;        /* proto_mesh_bin_write of g.mesh (NULL = none) */
    char mesh_etag[17];
    double mesh_ms, sdf_ms;   /* time to load the mesh and build its grid */
    proto_groom_json json;
} app_groom;

/* A procedural groom into *out (zeroed on failure): style name, counts (0 = GROOM_DEFAULT_STRANDS,
 * GROOM_DEFAULT_VERTS) and seed (0 = GROOM_DEFAULT_SEED). */
core_status app_groom_load_style(const char *style, uint32_t strands, uint32_t verts, uint64_t seed, app_groom *out,
                                 core_err *err);
/* A groom traced through the procedural hair mesh of a style (groom_hairmesh_procedural) into
 * *out (zeroed on failure), shown as "hairmesh:<style>": strands (0 = GROOM_DEFAULT_STRANDS)
 * rounded up to whole strands per face, verts vertices each (0 = GROOM_DEFAULT_VERTS), the
 * default colliders. */
core_status app_groom_load_hairmesh(const char *style, uint32_t strands, uint32_t verts, app_groom *out, core_err *err);
/* One of app_groom_styles into *out (zeroed on failure): app_groom_load_hairmesh for a
 * "hairmesh:<style>" (seed unused), app_groom_load_style otherwise. */
core_status app_groom_load_named(const char *name, uint32_t strands, uint32_t verts, uint64_t seed, app_groom *out,
                                 core_err *err);
/* A .tfx/.hair file at path into *out, shown to clients as "file:<label>"; verts 0 = the file's
 * count. */
core_status app_groom_load_path(const char *path, const char *label, uint32_t verts, app_groom *out, core_err *err);
void app_groom_free(app_groom *g);
/* (Re-)renders g's JSON after a change of its mesh. */
core_status app_groom_render(app_groom *g, core_err *err);
/* CORE_EINVAL (the counts in err) when g has more vertices than a groom may have
 * (PROTO_MAX_VERTICES: what set_groom and the hello's limits allow). Pure. */
core_status app_groom_check_size(const app_groom *g, core_err *err);

/* Gives g the mesh (taking it over; *mesh is zeroed, also on failure), named label: its SDF
 * over groom_collider_region (2 mm cells, at most GROOM_COLLIDER_MAX_CELLS samples; none when
 * the hair cannot reach the mesh), its binary and the re-rendered JSON. mesh NULL removes
 * g's mesh. (app_collider.c) */
core_status app_groom_set_collider(app_groom *g, core_mesh *mesh, const char *label, core_err *err);
/* Hands g's binaries to out's net: its groom data at APP_GROOM_PATH, its mesh at APP_MESH_PATH
 * and its hair mesh topology at APP_HAIRMESH_PATH (or none), each also under the room's page
 * path (PROTO_ROOM_PREFIX room "/groom.bin", ...), and to its NATS bridge for the edges (when
 * out->bus); before any message naming their tags is sent. Sim thread. */
struct app_outbox;
void app_groom_publish(struct app_outbox *out, const char *room, const app_groom *g);

#endif
