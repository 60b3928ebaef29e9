/* app: the groom and mesh files under the asset folder that set_groom may name. */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "app_assets.h"

static bool has_ext(const char *name, const char *ext)
{
    size_t n = strlen(name), e = strlen(ext);
    return n > e && strcasecmp(name + n - e, ext) == 0;
}

/* a layered hair mesh (.hairmesh.obj) is a groom, any other .obj a collision mesh */
static bool groom_ext(const char *name)
{
    return has_ext(name, ".tfx") || has_ext(name, ".hair") || has_ext(name, ".hairmesh.obj");
}
static bool mesh_ext(const char *name)
{
    return (has_ext(name, ".obj") && !has_ext(name, ".hairmesh.obj")) || has_ext(name, ".tfxmesh");
}

/* Adds files under dir/rel (depth-limited); names are relative to the asset folder. */
static void scan(app_assets *a, const proto_parser *parser, const char *root, const char *rel, int depth)
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
            scan(a, parser, root, child, depth - 1);
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
            if (proto_parse(parser, probe, strlen(probe), &m, &pe) != CORE_OK) continue;
            char *copy = strdup(child);
            if (copy) list[(*n)++] = copy;
        }
    }
    closedir(dir);
}

static int cmp_names(const void *x, const void *y) { return strcmp(*(char *const *)x, *(char *const *)y); }

void app_assets_list(app_assets *a, const char *dir, const proto_parser *parser)
{
    a->nfiles = a->nmeshes = 0;
    if (!dir) return;
    scan(a, parser, dir, "", 3);
    qsort(a->files, a->nfiles, sizeof a->files[0], cmp_names);
    qsort(a->meshes, a->nmeshes, sizeof a->meshes[0], cmp_names);
}

void app_assets_free(app_assets *a)
{
    for (size_t i = 0; i < a->nfiles; i++) free(a->files[i]);
    for (size_t i = 0; i < a->nmeshes; i++) free(a->meshes[i]);
    a->nfiles = a->nmeshes = 0;
}

size_t app_assets_find(char *const *list, size_t n, const char *name)
{
    size_t i = 0;
    while (i < n && strcmp(list[i], name) != 0) i++;
    return i;
}
