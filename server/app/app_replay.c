/* app: the --replay player: the recording read and checked up front, then its cursor. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "app_replay.h"
#include "groom/groom.h"

static core_status read_file(const char *path, uint8_t **out, size_t *len, core_err *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) return core_fail(err, CORE_EIO, "%s", strerror(errno));
    uint8_t *p = NULL;
    size_t n = 0, cap = 0;
    for (;;) {
        if (n == cap) {
            cap = cap ? cap * 2 : 65536;
            uint8_t *g = realloc(p, cap);
            if (!g) {
                free(p);
                fclose(f);
                return core_fail(err, CORE_ENOMEM, "out of memory reading %zu bytes", n);
            }
            p = g;
        }
        size_t got = fread(p + n, 1, cap - n, f);
        n += got;
        if (got == 0) break;
    }
    bool bad = ferror(f);
    fclose(f);
    if (bad) {
        free(p);
        return core_fail(err, CORE_EIO, "read error");
    }
    *out = p;
    *len = n;
    return CORE_OK;
}

/* The files the recording needs: the start's groom and collider, each set_groom's assets. */
static core_status check_files(const app_replay *r, const app_assets *as, const char *dir, core_err *err)
{
    groom_style style;
    if (groom_style_parse(r->start.groom, &style, NULL) != CORE_OK && access(r->start.groom, R_OK) != 0)
        return core_fail(err, CORE_EIO, "record 0 at byte %d: field groom: the groom file %s: %s", APP_REC_FILE_HEADER,
                         r->start.groom, strerror(errno));
    if (r->start.collider[0] && access(r->start.collider, R_OK) != 0)
        return core_fail(err, CORE_EIO, "record 0 at byte %d: field collider: the collision mesh %s: %s", APP_REC_FILE_HEADER,
                         r->start.collider, strerror(errno));
    for (size_t i = 0; i < r->n; i++) {
        const app_rec *c = &r->recs[i];
        if (c->kind != APP_REC_INPUT || c->msg.type != PROTO_SET_GROOM) continue;
        const char *file = c->msg.u.set_groom.file, *mesh = c->msg.u.set_groom.collider;
        if (c->msg.u.set_groom.is_file && app_assets_find(as->files, as->nfiles, file) == as->nfiles)
            return core_fail(err, CORE_EIO, "record %u at byte %zu: field file: no groom file \"%s\" in the asset folder %s",
                             c->index, c->offset, file, dir ? dir : "(none: give --assets DIR)");
        if (c->msg.u.set_groom.collider_mode == PROTO_COLLIDER_FILE && app_assets_find(as->meshes, as->nmeshes, mesh) == as->nmeshes)
            return core_fail(err, CORE_EIO, "record %u at byte %zu: field collider: no collision mesh \"%s\" in the asset folder %s",
                             c->index, c->offset, mesh, dir ? dir : "(none: give --assets DIR)");
    }
    return CORE_OK;
}

core_status app_replay_open(app_replay *r, const char *path, const proto_parser *p, const app_assets *as,
                            const char *assets_dir, core_err *err)
{
    memset(r, 0, sizeof *r);
    snprintf(r->path, sizeof r->path, "%s", path);
    uint8_t *data = NULL;
    size_t len = 0;
    core_err why;
    core_status st = read_file(path, &data, &len, &why);
    if (st != CORE_OK) return core_fail(err, st, "--replay %s: %s", path, why.msg);
    st = app_rec_read(data, len, p, &r->start, &r->recs, &r->n, &why);
    free(data);
    if (st == CORE_OK) st = check_files(r, as, assets_dir, &why);
    if (st != CORE_OK) {
        app_replay_free(r);
        return core_fail(err, st, "--replay %s: %s", path, why.msg);
    }
    r->end_step = r->recs[r->n - 1].step;
    r->active = true;
    return CORE_OK;
}

const proto_msg *app_replay_input(app_replay *r, uint64_t step)
{
    while (r->next < r->n && r->recs[r->next].step <= step && r->recs[r->next].kind == APP_REC_DIGEST) r->next++;
    if (r->next == r->n || r->recs[r->next].kind != APP_REC_INPUT || r->recs[r->next].step != step) return NULL;
    r->inputs++;
    return &r->recs[r->next++].msg;
}

bool app_replay_check(app_replay *r, uint64_t step, uint64_t digest, core_err *err)
{
    while (r->next < r->n && r->recs[r->next].step < step && r->recs[r->next].kind != APP_REC_END) r->next++;
    if (r->next == r->n || r->recs[r->next].kind != APP_REC_DIGEST || r->recs[r->next].step != step) return true;
    const app_rec *c = &r->recs[r->next++];
    r->digests++;
    if (c->digest == digest) return true;
    core_fail(err, CORE_ESTATE, "the positions after step %llu differ from the recording's (record %u at byte %zu: digest "
              "%016llx, replay %016llx)", (unsigned long long)step, c->index, c->offset, (unsigned long long)c->digest,
              (unsigned long long)digest);
    return false;
}

void app_replay_free(app_replay *r)
{
    free(r->recs);
    r->recs = NULL;
    r->n = 0;
}
