/* groom: collision mesh loaders (.obj, .tfxmesh text), pure bytes -> core_mesh, and by file. */
#include "groom.h"
#include "groom_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TFXMESH_MAX_BONES 65536u

/* Line-by-line reader over data[0, size); buf holds the current line, NUL-terminated, with
 * '\r' and '\t' turned into spaces. */
typedef struct text_cursor {
    const unsigned char *b;
    size_t size, off;
    uint32_t line; /* 1-based number of the line in buf */
    const char *what;
    char buf[GROOM_MESH_MAX_LINE + 1];
} text_cursor;

/* Growing vertex and triangle arrays. */
typedef struct mesh_build {
    float *pos;
    uint32_t *tri;
    uint32_t nverts, ntris, cap_v, cap_t;
} mesh_build;

/* Reads the next line into c->buf: 1 = got one, 0 = end of data, -1 = error (*st set). */
static int next_line(text_cursor *c, core_status *st, core_err *err)
{
    if (c->off >= c->size) return 0;
    c->line++;
    size_t n = 0;
    while (c->off < c->size) {
        unsigned char ch = c->b[c->off++];
        if (ch == '\n') break;
        if (n == GROOM_MESH_MAX_LINE) {
            *st = core_fail(err, CORE_EFORMAT, "%s: line %u is longer than %u bytes", c->what, c->line,
                            GROOM_MESH_MAX_LINE);
            return -1;
        }
        if (ch == '\r' || ch == '\t') ch = ' ';
        if (ch < 0x20 || ch == 0x7f) {
            *st = core_fail(err, CORE_EFORMAT, "%s: line %u: binary data (byte 0x%02x at offset %zu), not a text file",
                            c->what, c->line, ch, c->off - 1);
            return -1;
        }
        c->buf[n++] = (char)ch;
    }
    c->buf[n] = '\0';
    return 1;
}

static char *skip_ws(char *p)
{
    while (*p == ' ') p++;
    return p;
}

/* The token at *p (up to a space or the end) as a float; advances *p. 0 on a bad number. */
static int take_float(char **p, float *out)
{
    char *s = skip_ws(*p), *end;
    if (!*s) return 0;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || (*end && *end != ' ')) return 0;
    *out = (float)v;
    *p = end;
    return 1;
}

/* The integer at *p, which must end at a space, the end or (when slash) a '/'; advances *p. */
static int take_int(char **p, long long *out, int slash)
{
    char *s = skip_ws(*p), *end;
    if (!*s) return 0;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (end == s || errno == ERANGE || (*end && *end != ' ' && !(slash && *end == '/'))) return 0;
    *out = v;
    *p = end;
    return 1;
}

static core_status add_vertex(mesh_build *m, const text_cursor *c, const float v[3], core_err *err)
{
    for (int i = 0; i < 3; i++)
        if (!isfinite(v[i]) || fabsf(v[i]) > GROOM_MESH_MAX_COORD)
            return core_fail(err, CORE_EFORMAT, "%s: line %u: vertex coordinate %g is not finite or beyond %g m",
                             c->what, c->line, (double)v[i], (double)GROOM_MESH_MAX_COORD);
    if (m->nverts == GROOM_MESH_MAX_VERTS)
        return core_fail(err, CORE_EFORMAT, "%s: line %u: more than %u vertices", c->what, c->line,
                         GROOM_MESH_MAX_VERTS);
    if (m->nverts == m->cap_v) {
        uint32_t cap = m->cap_v ? m->cap_v * 2 : 1024;
        float *p = realloc(m->pos, (size_t)cap * 3 * sizeof *p);
        if (!p) return core_fail(err, CORE_ENOMEM, "%s: out of memory for %u vertices", c->what, cap);
        m->pos = p;
        m->cap_v = cap;
    }
    memcpy(m->pos + 3 * (size_t)m->nverts++, v, 3 * sizeof *v);
    return CORE_OK;
}

static core_status add_tri(mesh_build *m, const text_cursor *c, uint32_t a, uint32_t b, uint32_t d, core_err *err)
{
    if (a == b || b == d || a == d)
        return core_fail(err, CORE_EFORMAT, "%s: line %u: degenerate triangle (vertices %u %u %u)", c->what, c->line, a,
                         b, d);
    if (m->ntris == GROOM_MESH_MAX_TRIS)
        return core_fail(err, CORE_EFORMAT, "%s: line %u: more than %u triangles", c->what, c->line,
                         GROOM_MESH_MAX_TRIS);
    if (m->ntris == m->cap_t) {
        uint32_t cap = m->cap_t ? m->cap_t * 2 : 2048;
        uint32_t *p = realloc(m->tri, (size_t)cap * 3 * sizeof *p);
        if (!p) return core_fail(err, CORE_ENOMEM, "%s: out of memory for %u triangles", c->what, cap);
        m->tri = p;
        m->cap_t = cap;
    }
    uint32_t *t = m->tri + 3 * (size_t)m->ntris++;
    t[0] = a;
    t[1] = b;
    t[2] = d;
    return CORE_OK;
}

/* Hands the arrays to out after groom_mesh_check, or frees them. */
static core_status finish(mesh_build *m, const char *what, core_status st, core_mesh *out, core_err *err)
{
    if (st == CORE_OK && (m->nverts == 0 || m->ntris == 0))
        st = core_fail(err, CORE_EFORMAT, "%s: empty mesh (%u vertices, %u triangles)", what, m->nverts, m->ntris);
    if (st == CORE_OK) {
        core_mesh r = { m->nverts, m->ntris, m->pos, m->tri };
        core_err e;
        st = groom_mesh_check(&r, &e);
        if (st == CORE_OK) {
            *out = r;
            return CORE_OK;
        }
        core_fail(err, st, "%s: %s", what, e.msg);
    }
    free(m->pos);
    free(m->tri);
    return st;
}

/* Parses one `f` line (after the keyword) and fan-triangulates it. */
static core_status obj_face(mesh_build *m, const text_cursor *c, char *p, core_err *err)
{
    uint32_t first = 0, prev = 0, n = 0;
    for (p = skip_ws(p); *p; p = skip_ws(p)) {
        long long i;
        if (!take_int(&p, &i, 1))
            return core_fail(err, CORE_EFORMAT, "%s: line %u: bad face vertex '%.32s'", c->what, c->line, skip_ws(p));
        while (*p && *p != ' ') { /* the /vt/vn part */
            if (*p != '/' && *p != '-' && (*p < '0' || *p > '9'))
                return core_fail(err, CORE_EFORMAT, "%s: line %u: bad face vertex near '%.32s'", c->what, c->line, p);
            p++;
        }
        long long v = i > 0 ? i - 1 : (long long)m->nverts + i;
        if (i == 0 || v < 0 || v >= (long long)m->nverts)
            return core_fail(err, CORE_EFORMAT, "%s: line %u: vertex index %lld out of range (%u vertices so far)",
                             c->what, c->line, i, m->nverts);
        if (n == 0) first = (uint32_t)v;
        else if (n >= 2) {
            core_status st = add_tri(m, c, first, prev, (uint32_t)v, err);
            if (st != CORE_OK) return st;
        }
        prev = (uint32_t)v;
        n++;
    }
    if (n < 3)
        return core_fail(err, CORE_EFORMAT, "%s: line %u: a face needs at least 3 vertices (got %u)", c->what, c->line,
                         n);
    return CORE_OK;
}

core_status groom_mesh_load_obj(const void *data, size_t size, core_mesh *out, core_err *err)
{
    memset(out, 0, sizeof *out);
    text_cursor *c = calloc(1, sizeof *c);
    if (!c) return core_fail(err, CORE_ENOMEM, ".obj: out of memory");
    c->b = data;
    c->size = data ? size : 0;
    c->what = ".obj";
    mesh_build m = { 0 };
    core_status st = CORE_OK;
    while (st == CORE_OK && next_line(c, &st, err) == 1) {
        char *p = skip_ws(c->buf);
        if (p[0] == 'v' && (p[1] == ' ' || !p[1])) {
            float v[3];
            p++;
            if (!take_float(&p, &v[0]) || !take_float(&p, &v[1]) || !take_float(&p, &v[2]))
                st = core_fail(err, CORE_EFORMAT, "%s: line %u: a vertex needs 3 numbers (x y z)", c->what, c->line);
            else
                st = add_vertex(&m, c, v, err);
        } else if (p[0] == 'f' && (p[1] == ' ' || !p[1]))
            st = obj_face(&m, c, p + 1, err);
    }
    st = finish(&m, ".obj", st, out, err);
    free(c);
    return st;
}

/* Next line that is neither blank nor a comment: 1, 0 at the end, -1 on error. */
static int next_data_line(text_cursor *c, char **p, core_status *st, core_err *err)
{
    int r;
    while ((r = next_line(c, st, err)) == 1) {
        *p = skip_ws(c->buf);
        if (**p && **p != '#') return 1;
    }
    return r;
}

/* Reads `key N` with N in [lo, hi] from the line at p. */
static core_status tfx_count(const text_cursor *c, char *p, const char *key, uint32_t lo, uint32_t hi, uint32_t *n,
                             core_err *err)
{
    size_t k = strlen(key);
    long long v;
    if (strncmp(p, key, k) != 0 || p[k] != ' ')
        return core_fail(err, CORE_EFORMAT, "%s: line %u: expected '%s N', got '%.32s'", c->what, c->line, key, p);
    p += k;
    if (!take_int(&p, &v, 0) || *skip_ws(p))
        return core_fail(err, CORE_EFORMAT, "%s: line %u: bad %s count", c->what, c->line, key);
    if (v < lo || v > hi)
        return core_fail(err, CORE_EFORMAT, "%s: line %u: %s %lld out of range [%u, %u]", c->what, c->line, key, v, lo,
                         hi);
    *n = (uint32_t)v;
    return CORE_OK;
}

/* The next data line, or a truncation error naming what was expected (item i of n; n = 0 for
 * a single line). */
static core_status tfx_need(text_cursor *c, char **p, const char *what, uint32_t i, uint32_t n, core_err *err)
{
    core_status st = CORE_OK;
    int r = next_data_line(c, p, &st, err);
    if (r == 1) return CORE_OK;
    if (r < 0) return st;
    if (n == 0)
        return core_fail(err, CORE_EFORMAT, "%s: truncated: the file ends after line %u, expecting %s", c->what, c->line,
                         what);
    return core_fail(err, CORE_EFORMAT, "%s: truncated: the file ends after line %u, expecting %s %u of %u", c->what,
                     c->line, what, i, n);
}

/* Parses the leading "i" of a vertex or triangle line, which must equal want. */
static core_status tfx_index(const text_cursor *c, char **p, const char *what, uint32_t want, core_err *err)
{
    long long i;
    if (!take_int(p, &i, 0))
        return core_fail(err, CORE_EFORMAT, "%s: line %u: bad %s line '%.32s'", c->what, c->line, what, c->buf);
    if (i != want)
        return core_fail(err, CORE_EFORMAT, "%s: line %u: %s index %lld, expected %u", c->what, c->line, what, i, want);
    return CORE_OK;
}

static core_status tfx_parse(text_cursor *c, mesh_build *m, core_err *err)
{
    char *p = NULL;
    uint32_t n = 0;
    core_status st = CORE_OK;
    int r = next_data_line(c, &p, &st, err);
    if (r < 0) return st;
    if (r == 0) return core_fail(err, CORE_EFORMAT, "%s: empty file (no data lines)", c->what);
    if (st == CORE_OK && strncmp(p, "numOfBones", 10) == 0) {
        st = tfx_count(c, p, "numOfBones", 0, TFXMESH_MAX_BONES, &n, err);
        for (uint32_t i = 0; st == CORE_OK && i < n; i++) st = tfx_need(c, &p, "bone", i, n, err);
        if (st == CORE_OK) st = tfx_need(c, &p, "numOfVertices", 0, 0, err);
    }
    if (st == CORE_OK) st = tfx_count(c, p, "numOfVertices", 1, GROOM_MESH_MAX_VERTS, &n, err);
    for (uint32_t i = 0; st == CORE_OK && i < n; i++) {
        float v[3];
        st = tfx_need(c, &p, "vertex", i, n, err);
        if (st == CORE_OK) st = tfx_index(c, &p, "vertex", i, err);
        if (st == CORE_OK && (!take_float(&p, &v[0]) || !take_float(&p, &v[1]) || !take_float(&p, &v[2])))
            st = core_fail(err, CORE_EFORMAT, "%s: line %u: vertex %u needs 3 numbers (x y z)", c->what, c->line, i);
        if (st == CORE_OK) st = add_vertex(m, c, v, err);
    }
    if (st == CORE_OK) st = tfx_need(c, &p, "numOfTriangles", 0, 0, err);
    if (st == CORE_OK) st = tfx_count(c, p, "numOfTriangles", 1, GROOM_MESH_MAX_TRIS, &n, err);
    for (uint32_t i = 0; st == CORE_OK && i < n; i++) {
        long long v[3];
        st = tfx_need(c, &p, "triangle", i, n, err);
        if (st == CORE_OK) st = tfx_index(c, &p, "triangle", i, err);
        if (st != CORE_OK) break;
        if (!take_int(&p, &v[0], 0) || !take_int(&p, &v[1], 0) || !take_int(&p, &v[2], 0) || *skip_ws(p)) {
            st = core_fail(err, CORE_EFORMAT, "%s: line %u: triangle %u needs 3 vertex indices", c->what, c->line, i);
            break;
        }
        for (int k = 0; k < 3 && st == CORE_OK; k++)
            if (v[k] < 0 || v[k] >= (long long)m->nverts)
                st = core_fail(err, CORE_EFORMAT, "%s: line %u: triangle %u: vertex index %lld out of range (%u vertices)",
                               c->what, c->line, i, v[k], m->nverts);
        if (st == CORE_OK) st = add_tri(m, c, (uint32_t)v[0], (uint32_t)v[1], (uint32_t)v[2], err);
    }
    if (st != CORE_OK) return st;
    r = next_data_line(c, &p, &st, err);
    if (r == 1)
        return core_fail(err, CORE_EFORMAT, "%s: line %u: unexpected data after the %u triangles", c->what, c->line,
                         m->ntris);
    return r < 0 ? st : CORE_OK;
}

core_status groom_mesh_load_tfxmesh(const void *data, size_t size, core_mesh *out, core_err *err)
{
    memset(out, 0, sizeof *out);
    text_cursor *c = calloc(1, sizeof *c);
    if (!c) return core_fail(err, CORE_ENOMEM, ".tfxmesh: out of memory");
    c->b = data;
    c->size = data ? size : 0;
    c->what = ".tfxmesh";
    mesh_build m = { 0 };
    core_status st = tfx_parse(c, &m, err);
    st = finish(&m, ".tfxmesh", st, out, err);
    free(c);
    return st;
}

core_status groom_mesh_load_file(const char *path, core_mesh *out, core_err *err)
{
    memset(out, 0, sizeof *out);
    if (!path) return core_fail(err, CORE_EINVAL, "no mesh file path");
    int obj = groom_has_ext(path, ".obj"), tfx = groom_has_ext(path, ".tfxmesh");
    if (!obj && !tfx)
        return core_fail(err, CORE_EINVAL, "mesh file '%s' has an unknown extension (expected .obj or .tfxmesh)", path);
    unsigned char *data = NULL;
    size_t size = 0;
    core_status st = groom_read_all(path, GROOM_MESH_MAX_FILE_BYTES, "mesh file", &data, &size, err);
    if (st != CORE_OK) return st;
    core_err e;
    st = obj ? groom_mesh_load_obj(data, size, out, &e) : groom_mesh_load_tfxmesh(data, size, out, &e);
    free(data);
    if (st != CORE_OK) return core_fail(err, st, "%s: %s", path, e.msg);
    return CORE_OK;
}
