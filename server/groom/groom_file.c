/* groom: reads a groom file from disk and dispatches to the loader for its extension; the
 * file reader shared with the mesh loader. */
#include "groom.h"
#include "groom_internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

int groom_has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    return n > e && strcasecmp(path + n - e, ext) == 0;
}

core_status groom_read_all(const char *path, size_t max_bytes, const char *what, unsigned char **data, size_t *size,
                           core_err *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) return core_fail(err, CORE_EIO, "cannot open %s '%s': %s", what, path, strerror(errno));
    size_t cap = 1 << 16, n = 0;
    unsigned char *buf = malloc(cap);
    core_status st = buf ? CORE_OK : core_fail(err, CORE_ENOMEM, "out of memory reading '%s'", path);
    while (st == CORE_OK) {
        if (n > max_bytes) {
            st = core_fail(err, CORE_EINVAL, "%s '%s' is larger than %zu bytes", what, path, max_bytes);
            break;
        }
        if (n == cap) { /* grow, at most to one byte past the cap so oversize files are seen */
            size_t ncap = cap * 2 > max_bytes + 1 ? max_bytes + 1 : cap * 2;
            unsigned char *nb = realloc(buf, ncap);
            if (!nb) {
                st = core_fail(err, CORE_ENOMEM, "out of memory reading '%s' (%zu bytes so far)", path, n);
                break;
            }
            buf = nb;
            cap = ncap;
        }
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (got == 0) {
            if (ferror(f)) st = core_fail(err, CORE_EIO, "error reading %s '%s'", what, path);
            break;
        }
    }
    fclose(f);
    if (st != CORE_OK) {
        free(buf);
        return st;
    }
    *data = buf;
    *size = n;
    return CORE_OK;
}

/* The guides traced through the layered hair mesh of a .hairmesh.obj image: whole strands per
 * face, GROOM_DEFAULT_STRANDS or a little more in all, nverts each (0 = GROOM_DEFAULT_VERTS). */
static core_status load_hairmesh(const unsigned char *data, size_t size, uint32_t nverts, core_groom *out, core_err *err)
{
    core_hairmesh m;
    core_status st = groom_hairmesh_load_obj(data, size, &m, err);
    if (st != CORE_OK) return st;
    st = groom_from_hairmesh(&m, (GROOM_DEFAULT_STRANDS + m.nfaces - 1) / m.nfaces, nverts ? nverts : GROOM_DEFAULT_VERTS,
                             out, err);
    core_hairmesh_free(&m);
    return st;
}

core_status groom_load_file(const char *path, uint32_t nverts, core_groom *out, core_err *err)
{
    memset(out, 0, sizeof *out);
    if (!path) return core_fail(err, CORE_EINVAL, "no groom file path");
    int tfx = groom_has_ext(path, ".tfx"), hair = groom_has_ext(path, ".hair"), hm = groom_has_ext(path, ".hairmesh.obj");
    if (!tfx && !hair && !hm)
        return core_fail(err, CORE_EINVAL,
                         "groom file '%s' has an unknown extension (expected .tfx, .hair or .hairmesh.obj)", path);
    unsigned char *data = NULL;
    size_t size = 0;
    core_status st = groom_read_all(path, GROOM_MAX_FILE_BYTES, "groom file", &data, &size, err);
    if (st != CORE_OK) return st;
    core_err e;
    st = tfx    ? groom_load_tfx(data, size, nverts, out, &e)
         : hair ? groom_load_hair(data, size, nverts, out, &e)
                : load_hairmesh(data, size, nverts, out, &e);
    free(data);
    if (st != CORE_OK) return core_fail(err, st, "%s: %s", path, e.msg);
    groom_fit_colliders(out);
    return CORE_OK;
}
