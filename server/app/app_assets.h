/* app: the asset folder's listing: the .tfx/.hair grooms and .obj/.tfxmesh collision meshes
 * set_groom may name (relative names, sorted). Built once at start-up (main thread), then
 * read-only: any thread may read it. */
#ifndef APP_ASSETS_H
#define APP_ASSETS_H

#include <stddef.h>

#include "proto/proto.h"

#define APP_MAX_FILES 256 /* files of each kind listed from the asset folder */

typedef struct app_assets {
    char *files[APP_MAX_FILES];  /* grooms */
    size_t nfiles;
    char *meshes[APP_MAX_FILES]; /* collision meshes */
    size_t nmeshes;
} app_assets;

/* Lists dir (NULL = nothing), three folders deep, keeping the names parser accepts as set_groom
 * file names. The caller owns the lists (app_assets_free). */
void app_assets_list(app_assets *a, const char *dir, const proto_parser *parser);
void app_assets_free(app_assets *a);
/* The index of name in list[0, n), or n. Pure. */
size_t app_assets_find(char *const *list, size_t n, const char *name);

#endif
