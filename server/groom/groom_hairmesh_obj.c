/* groom: layered hair meshes in Wavefront .obj (the layers' vertices, the root faces): read and write. */
#include "groom.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define WHAT "hair mesh .obj"

/* The parser's state: the current line (NUL-terminated, tabs and CR as spaces), the vertices and
 * the faces read so far (4 zero-based indices each, CORE_HAIRMESH_NONE for a triangle's 4th). */
typedef struct hm_reader {
    const unsigned char *b;
    size_t size, off;
    uint32_t line;
    char buf[GROOM_MESH_MAX_LINE + 1];
    float *pos;
    uint32_t nverts, cap_v;
    uint32_t *faces;
    uint32_t nfaces, cap_f;
} hm_reader;

/* 1 = a line is in r->buf, 0 = end of data, -1 = error (*st set). */
static int read_line(hm_reader *r, core_status *st, core_err *err)
{
    if (r->off >= r->size) return 0;
    r->line++;
    size_t n = 0;
    while (r->off < r->size) {
        unsigned char ch = r->b[r->off++];
        if (ch == '\n') break;
        if (n == GROOM_MESH_MAX_LINE) {
            *st = core_fail(err, CORE_EFORMAT, WHAT ": line %u is longer than %u bytes", r->line, GROOM_MESH_MAX_LINE);
            return -1;
        }
        if (ch == '\r' || ch == '\t') ch = ' ';
        if (ch < 0x20 || ch == 0x7f) {
            *st = core_fail(err, CORE_EFORMAT, WHAT ": line %u: binary data (byte 0x%02x), not a text file", r->line, ch);
            return -1;
        }
        r->buf[n++] = (char)ch;
    }
    r->buf[n] = '\0';
    return 1;
}

static char *ws(char *p)
{
    while (*p == ' ') p++;
    return p;
}

static core_status vertex_line(hm_reader *r, char *p, core_err *err)
{
    float v[3];
    for (int k = 0; k < 3; k++) {
        char *s = ws(p), *end;
        double d = strtod(s, &end);
        if (end == s || (*end && *end != ' '))
            return core_fail(err, CORE_EFORMAT, WHAT ": line %u: a vertex needs 3 numbers (x y z)", r->line);
        if (!(fabs(d) <= CORE_HAIRMESH_MAX_COORD))
            return core_fail(err, CORE_EFORMAT, WHAT ": line %u: coordinate %g is not finite or beyond %g m", r->line, d,
                             (double)CORE_HAIRMESH_MAX_COORD);
        v[k] = (float)d;
        p = end;
    }
    if (r->nverts == CORE_HAIRMESH_MAX_VERTS)
        return core_fail(err, CORE_EFORMAT, WHAT ": line %u: more than %u vertices", r->line, CORE_HAIRMESH_MAX_VERTS);
    if (r->nverts == r->cap_v) {
        uint32_t cap = r->cap_v ? 2 * r->cap_v : 256;
        float *q = realloc(r->pos, (size_t)cap * 3 * sizeof *q);
        if (!q) return core_fail(err, CORE_ENOMEM, WHAT ": out of memory for %u vertices", cap);
        r->pos = q, r->cap_v = cap;
    }
    memcpy(r->pos + 3 * (size_t)r->nverts++, v, sizeof v);
    return CORE_OK;
}

static core_status face_line(hm_reader *r, char *p, core_err *err)
{
    uint32_t c[4] = { CORE_HAIRMESH_NONE, CORE_HAIRMESH_NONE, CORE_HAIRMESH_NONE, CORE_HAIRMESH_NONE }, n = 0;
    for (p = ws(p); *p; p = ws(p)) {
        char *end;
        errno = 0;
        long long i = strtoll(p, &end, 10);
        if (end == p || errno == ERANGE || (*end && *end != ' ' && *end != '/'))
            return core_fail(err, CORE_EFORMAT, WHAT ": line %u: bad face vertex '%.32s'", r->line, p);
        for (p = end; *p && *p != ' '; p++)
            if (*p != '/' && *p != '-' && (*p < '0' || *p > '9'))
                return core_fail(err, CORE_EFORMAT, WHAT ": line %u: bad face vertex near '%.32s'", r->line, p);
        long long v = i > 0 ? i - 1 : (long long)r->nverts + i;
        if (i == 0 || v < 0 || v >= (long long)r->nverts)
            return core_fail(err, CORE_EFORMAT, WHAT ": line %u: vertex index %lld out of range (%u vertices so far)",
                             r->line, i, r->nverts);
        if (n == 4) return core_fail(err, CORE_EFORMAT, WHAT ": line %u: a hair mesh face has 3 or 4 vertices", r->line);
        c[n++] = (uint32_t)v;
    }
    if (n < 3) return core_fail(err, CORE_EFORMAT, WHAT ": line %u: a face needs 3 or 4 vertices (got %u)", r->line, n);
    if (r->nfaces == CORE_HAIRMESH_MAX_FACES)
        return core_fail(err, CORE_EFORMAT, WHAT ": line %u: more than %u faces", r->line, CORE_HAIRMESH_MAX_FACES);
    if (r->nfaces == r->cap_f) {
        uint32_t cap = r->cap_f ? 2 * r->cap_f : 256;
        uint32_t *q = realloc(r->faces, (size_t)cap * 4 * sizeof *q);
        if (!q) return core_fail(err, CORE_ENOMEM, WHAT ": out of memory for %u faces", cap);
        r->faces = q, r->cap_f = cap;
    }
    memcpy(r->faces + 4 * (size_t)r->nfaces++, c, sizeof c);
    return CORE_OK;
}

/* Builds out from the vertices and root faces read. */
static core_status assemble(const hm_reader *r, core_hairmesh *out, core_err *err)
{
    if (r->nfaces == 0 || r->nverts == 0)
        return core_fail(err, CORE_EFORMAT, WHAT ": no hair mesh (%u vertices, %u faces)", r->nverts, r->nfaces);
    uint32_t ncols = 0;
    for (size_t i = 0; i < 4 * (size_t)r->nfaces; i++)
        if (r->faces[i] != CORE_HAIRMESH_NONE && r->faces[i] + 1 > ncols) ncols = r->faces[i] + 1;
    if (ncols < 3 || r->nverts % ncols != 0 || r->nverts / ncols < 2)
        return core_fail(err, CORE_EFORMAT,
                         WHAT ": the faces use vertices 1..%u (the root layer), but %u vertices are not 2 or more "
                         "whole layers of %u",
                         ncols, r->nverts, ncols);
    uint32_t nl = r->nverts / ncols;
    core_err e;
    core_status st = core_hairmesh_alloc(out, ncols, nl, r->nfaces, 0, 0, &e);
    if (st != CORE_OK) return core_fail(err, st == CORE_ENOMEM ? st : CORE_EFORMAT, WHAT ": %s", e.msg);
    for (uint32_t l = 0; l < nl; l++)
        for (uint32_t c = 0; c < ncols; c++)
            memcpy(out->pos + 3 * ((size_t)c * nl + l), r->pos + 3 * ((size_t)l * ncols + c), 3 * sizeof(float));
    memcpy(out->faces, r->faces, (size_t)r->nfaces * 4 * sizeof(uint32_t));
    st = core_hairmesh_validate(out, &e);
    if (st != CORE_OK) {
        core_hairmesh_free(out);
        return core_fail(err, st, WHAT ": %s", e.msg);
    }
    return CORE_OK;
}

core_status groom_hairmesh_load_obj(const void *data, size_t size, core_hairmesh *out, core_err *err)
{
    memset(out, 0, sizeof *out);
    hm_reader *r = calloc(1, sizeof *r);
    if (!r) return core_fail(err, CORE_ENOMEM, WHAT ": out of memory");
    r->b = data;
    r->size = data ? size : 0;
    core_status st = CORE_OK;
    while (st == CORE_OK && read_line(r, &st, err) == 1) {
        char *p = ws(r->buf);
        if (p[0] == 'v' && (p[1] == ' ' || !p[1])) st = vertex_line(r, p + 1, err);
        else if (p[0] == 'f' && (p[1] == ' ' || !p[1])) st = face_line(r, p + 1, err);
    }
    if (st == CORE_OK) st = assemble(r, out, err);
    free(r->pos);
    free(r->faces);
    free(r);
    return st;
}

core_status groom_hairmesh_write_obj(const core_hairmesh *m, char **out, size_t *len, core_err *err)
{
    *out = NULL;
    *len = 0;
    char *buf = NULL;
    size_t n = 0;
    FILE *f = open_memstream(&buf, &n);
    if (!f) return core_fail(err, CORE_ENOMEM, "out of memory writing a hair mesh");
    fprintf(f, "# strandcast hair mesh: %u columns x %u layers, root layer first; faces are the root layer's\n",
            m->ncols, m->nlayers);
    for (uint32_t l = 0; l < m->nlayers; l++)
        for (uint32_t c = 0; c < m->ncols; c++) {
            const float *p = m->pos + 3 * ((size_t)c * m->nlayers + l);
            fprintf(f, "v %.9g %.9g %.9g\n", (double)p[0], (double)p[1], (double)p[2]);
        }
    for (uint32_t k = 0; k < m->nfaces; k++) {
        const uint32_t *c = m->faces + 4 * (size_t)k;
        if (c[3] == CORE_HAIRMESH_NONE) fprintf(f, "f %u %u %u\n", c[0] + 1, c[1] + 1, c[2] + 1);
        else fprintf(f, "f %u %u %u %u\n", c[0] + 1, c[1] + 1, c[2] + 1, c[3] + 1);
    }
    if (fclose(f) != 0 || !buf) {
        free(buf);
        return core_fail(err, CORE_ENOMEM, "out of memory writing a hair mesh");
    }
    *out = buf;
    *len = n;
    return CORE_OK;
}
