/* app: loads the live groom (procedural style or file) and renders its JSON. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app_groom.h"
#include "groom/groom.h"

const char *const app_groom_styles[APP_NSTYLES] = { "straight",          "wavy",          "curly",
                                                     "hairmesh:straight", "hairmesh:wavy", "hairmesh:curly" };

core_status app_groom_render(app_groom *g, core_err *err)
{
    proto_data_ref dr = { APP_GROOM_PATH, g->groom_etag, g->groom_bin ? net_buf_len(g->groom_bin) : 0 };
    proto_mesh_ref mr = { g->collider, APP_MESH_PATH, g->mesh_etag, g->mesh_bin ? net_buf_len(g->mesh_bin) : 0 };
    proto_data_ref hr = { APP_HAIRMESH_PATH, g->hairmesh_etag, g->hairmesh_bin ? net_buf_len(g->hairmesh_bin) : 0 };
    proto_groom pg = { g->source, &g->g, g->seed, &dr, g->g.mesh && g->mesh_bin ? &mr : NULL,
                       g->g.hairmesh && g->hairmesh_bin ? &hr : NULL };
    proto_groom_json_free(&g->json);
    return proto_groom_json_build(&g->json, &pg, err);
}

/* The hair mesh topology binary of out's hair mesh (none without one). */
static core_status hairmesh_bin(app_groom *out, core_err *err)
{
    const core_hairmesh *m = out->g.hairmesh;
    if (!m) return CORE_OK;
    size_t n = proto_hairmesh_bin_size(m);
    out->hairmesh_bin = net_buf_new(n);
    if (!out->hairmesh_bin) return core_fail(err, CORE_ENOMEM, "out of memory for the hair mesh binary (%zu bytes)", n);
    proto_hairmesh_bin_write(m, net_buf_data(out->hairmesh_bin));
    proto_bin_etag(net_buf_data(out->hairmesh_bin), n, out->hairmesh_etag);
    return CORE_OK;
}

/* The groom data binary (and the hair mesh's), then the JSON that names them. */
static core_status finish(app_groom *out, core_err *err)
{
    size_t n = proto_groom_bin_size(&out->g);
    out->groom_bin = net_buf_new(n);
    if (!out->groom_bin) {
        app_groom_free(out);
        return core_fail(err, CORE_ENOMEM, "out of memory for the groom data binary (%zu bytes)", n);
    }
    proto_groom_bin_write(&out->g, net_buf_data(out->groom_bin));
    proto_bin_etag(net_buf_data(out->groom_bin), n, out->groom_etag);
    core_status st = hairmesh_bin(out, err);
    if (st == CORE_OK) st = app_groom_render(out, err);
    if (st != CORE_OK) app_groom_free(out);
    return st;
}

core_status app_groom_load_style(const char *style, uint32_t strands, uint32_t verts, uint64_t seed, app_groom *out,
                                 core_err *err)
{
    memset(out, 0, sizeof *out);
    groom_desc gd = { 0 };
    core_status st = groom_style_parse(style, &gd.style, err);
    if (st != CORE_OK) return st;
    gd.nstrands = strands ? strands : GROOM_DEFAULT_STRANDS;
    gd.nverts = verts ? verts : GROOM_DEFAULT_VERTS;
    gd.seed = seed ? seed : GROOM_DEFAULT_SEED;
    if ((st = groom_procedural(&gd, &out->g, err)) != CORE_OK) return st;
    snprintf(out->source, sizeof out->source, "procedural:%s", groom_style_name(gd.style));
    out->seed = gd.seed;
    return finish(out, err);
}

core_status app_groom_load_hairmesh(const char *style, uint32_t strands, uint32_t verts, app_groom *out, core_err *err)
{
    memset(out, 0, sizeof *out);
    groom_hairmesh_desc hd = { 0 };
    core_status st = groom_style_parse(style, &hd.style, err);
    if (st != CORE_OK) return st;
    core_hairmesh m;
    if ((st = groom_hairmesh_procedural(&hd, &m, err)) != CORE_OK) return st;
    uint32_t want = strands ? strands : GROOM_DEFAULT_STRANDS;
    uint32_t per_face = (want + m.nfaces - 1) / m.nfaces;
    st = groom_from_hairmesh(&m, per_face, verts ? verts : GROOM_DEFAULT_VERTS, &out->g, err);
    core_hairmesh_free(&m);
    if (st != CORE_OK) return st;
    groom_default_colliders(&out->g);
    snprintf(out->source, sizeof out->source, "hairmesh:%s", groom_style_name(hd.style));
    return finish(out, err);
}

core_status app_groom_load_named(const char *name, uint32_t strands, uint32_t verts, uint64_t seed, app_groom *out,
                                 core_err *err)
{
    if (strncmp(name, "hairmesh:", 9) == 0) return app_groom_load_hairmesh(name + 9, strands, verts, out, err);
    return app_groom_load_style(name, strands, verts, seed, out, err);
}

core_status app_groom_load_path(const char *path, const char *label, uint32_t verts, app_groom *out, core_err *err)
{
    memset(out, 0, sizeof *out);
    core_status st = groom_load_file(path, verts, &out->g, err);
    if (st != CORE_OK) return st;
    snprintf(out->source, sizeof out->source, "file:%s", label);
    return finish(out, err);
}

core_status app_groom_check_size(const app_groom *g, core_err *err)
{
    uint64_t nv = (uint64_t)g->g.nstrands * g->g.nverts;
    if (nv <= PROTO_MAX_VERTICES) return CORE_OK;
    return core_fail(err, CORE_EINVAL, "%s: %u strands x %u vertices = %llu, over the %u a groom may have (a smaller verts count fits it)",
                     g->source, g->g.nstrands, g->g.nverts, (unsigned long long)nv, PROTO_MAX_VERTICES);
}

void app_groom_free(app_groom *g)
{
    core_groom_free(&g->g);
    net_buf_unref(g->groom_bin);
    net_buf_unref(g->hairmesh_bin);
    net_buf_unref(g->mesh_bin);
    proto_groom_json_free(&g->json);
    memset(g, 0, sizeof *g);
}
