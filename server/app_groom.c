/* app: loads the live groom (procedural style or file), renders its JSON, lists asset files (grooms, meshes). */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "app_internal.h"
#include "groom/groom.h"

core_status app_groom_render(app_groom *g, core_err *err)
{
    proto_mesh_ref mr = { g->collider, APP_MESH_PATH, g->mesh_etag, g->mesh_bin ? net_buf_len(g->mesh_bin) : 0 };
    proto_groom pg = { g->source, &g->g, g->seed, g->g.mesh && g->mesh_bin ? &mr : NULL };
    proto_groom_json_free(&g->json);
    return proto_groom_json_build(&g->json, &pg, err);
}

static core_status finish(app_groom *out, core_err *err)
{
    core_status st = app_groom_render(out, err);
    if (st != CORE_OK) app_groom_free(out);
    return st;
}

core_status app_groom_load_style(app *a, const char *style, uint32_t strands, uint32_t verts, uint64_t seed,
                                 app_groom *out, core_err *err)
{
    (void)a;
    memset(out, 0, sizeof *out);
    groom_desc gd = { 0 };
    core_status st = groom_style_parse(style, &gd.style, err);
    if (st != CORE_OK) return st;
    gd.nstrands = strands ? strands : APP_DEFAULT_STRANDS;
    gd.nverts = verts ? verts : APP_DEFAULT_VERTS;
    gd.seed = seed ? seed : GROOM_DEFAULT_SEED;
    if ((st = groom_procedural(&gd, &out->g, err)) != CORE_OK) return st;
    snprintf(out->source, sizeof out->source, "procedural:%s", groom_style_name(gd.style));
    out->seed = gd.seed;
    return finish(out, err);
}

core_status app_groom_load_path(app *a, const char *path, const char *label, uint32_t verts, app_groom *out,
                                core_err *err)
{
    (void)a;
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
    net_buf_unref(g->mesh_bin);
    proto_groom_json_free(&g->json);
    memset(g, 0, sizeof *g);
}

static bool has_ext(const char *name, const char *ext)
{
    size_t n = strlen(name), e = strlen(ext);
    return n > e && strcasecmp(name + n - e, ext) == 0;
}

static bool groom_ext(const char *name) { return has_ext(name, ".tfx") || has_ext(name, ".hair"); }
static bool mesh_ext(const char *name) { return has_ext(name, ".obj") || has_ext(name, ".tfxmesh"); }

/* Adds files under dir/rel (depth-limited); names are relative to the asset folder. */
static void scan(app *a, const char *root, const char *rel, int depth)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", root, rel);
    DIR *dir = opendir(path);
    if (!dir) return;
    struct dirent *de;
    while ((de = readdir(dir))) {
        if (de->d_name[0] == '.') continue;
        char child[PROTO_MAX_NAME + 2];
        int w = snprintf(child, sizeof child, "%s%s%s", rel, *rel ? "/" : "", de->d_name);
        if (w < 0 || (size_t)w > PROTO_MAX_NAME) continue;
        char full[1400];
        snprintf(full, sizeof full, "%s/%s", root, child);
        struct stat sb;
        if (stat(full, &sb) != 0) continue;
        if (S_ISDIR(sb.st_mode) && depth > 0) {
            scan(a, root, child, depth - 1);
        } else if (S_ISREG(sb.st_mode) && (groom_ext(de->d_name) || mesh_ext(de->d_name))) {
            bool groom = groom_ext(de->d_name);
            char **list = groom ? a->files : a->meshes;
            size_t *n = groom ? &a->nfiles : &a->nmeshes;
            if (*n >= APP_MAX_FILES) continue;
            /* only names set_groom can ask for (proto's file-name rules) */
            proto_error pe;
            proto_msg m;
            char probe[PROTO_MAX_NAME + 64];
            snprintf(probe, sizeof probe, "{\"type\":\"set_groom\",\"style\":\"straight\",\"collider\":\"%s\"}", child);
            if (proto_parse(&a->parser, probe, strlen(probe), &m, &pe) != CORE_OK) continue;
            char *copy = strdup(child);
            if (copy) list[(*n)++] = copy;
        }
    }
    closedir(dir);
}

static int cmp_names(const void *x, const void *y) { return strcmp(*(char *const *)x, *(char *const *)y); }

void app_list_assets(app *a)
{
    a->nfiles = a->nmeshes = 0;
    if (!a->d.assets_dir) return;
    scan(a, a->d.assets_dir, "", 3);
    qsort(a->files, a->nfiles, sizeof a->files[0], cmp_names);
    qsort(a->meshes, a->nmeshes, sizeof a->meshes[0], cmp_names);
}

void app_free_assets(app *a)
{
    for (size_t i = 0; i < a->nfiles; i++) free(a->files[i]);
    for (size_t i = 0; i < a->nmeshes; i++) free(a->meshes[i]);
    a->nfiles = a->nmeshes = 0;
}
