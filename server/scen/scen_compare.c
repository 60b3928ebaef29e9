/* scen: `strandcastc --compare A.scfr B.scfr`: the largest position difference per frame of two
 * recorded position files (backend against backend, before against after a change). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scen.h"

static const char *const COMPARE_USAGE =
    "usage: strandcastc --compare A.scfr B.scfr [--json]\n"
    "Compares two position files written by strandcastc --out (SCFR): for each frame, the largest\n"
    "distance between the same vertex in A and in B (metres) and where it is; then the largest over\n"
    "all frames, with its frame, strand and vertex. A non-finite position counts as an infinite\n"
    "difference.\n"
    "  --json   one JSON object per frame, {\"frame\":I,\"max_diff\":D,\"strand\":S,\"vertex\":V}, then\n"
    "           {\"summary\":true,\"frames\":N,\"max_diff\":D,\"frame\":I,\"strand\":S,\"vertex\":V,\"identical\":B}\n"
    "Exit status: 0 when both files decode and have the same shape (whatever the differences), 1 when\n"
    "they cannot be compared (unreadable, not SCFR, truncated, different strand, vertex or frame\n"
    "counts; the message says which), 2 for bad flags.\n";

/* One open SCFR file. */
typedef struct scfr {
    const char *path;
    FILE *f;
    uint32_t strands, verts, frames;
} scfr;

static int open_scfr(scfr *s, const char *path)
{
    s->path = path;
    if (!(s->f = fopen(path, "rb"))) {
        fprintf(stderr, "strandcastc: --compare: %s: %s\n", path, strerror(errno));
        return 1;
    }
    unsigned char h[16];
    if (fread(h, 1, sizeof h, s->f) != sizeof h || memcmp(h, "SCFR", 4) != 0) {
        fprintf(stderr, "strandcastc: --compare: %s: not an SCFR position file (no 16-byte \"SCFR\" header)\n", path);
        return 1;
    }
    uint32_t v[3];
    memcpy(v, h + 4, sizeof v);
    s->strands = v[0], s->verts = v[1], s->frames = v[2];
    if (fseek(s->f, 0, SEEK_END) != 0) return 1;
    long size = ftell(s->f);
    unsigned long long want = 16ull + (unsigned long long)s->strands * s->verts * 12ull * s->frames;
    if (size < 0 || (unsigned long long)size != want) {
        fprintf(stderr, "strandcastc: --compare: %s: %ld bytes, its header (%u strands x %u vertices, %u frames) says %llu "
                "(truncated or corrupt)\n", path, size, s->strands, s->verts, s->frames, want);
        return 1;
    }
    return fseek(s->f, 16, SEEK_SET) != 0;
}

/* The largest vertex distance between two frames of n vertices; *at its vertex index. */
static double frame_diff(const float *a, const float *b, size_t n, size_t *at)
{
    double worst = -1.0;
    *at = 0;
    for (size_t i = 0; i < n; i++) {
        double dx = (double)a[3 * i] - b[3 * i], dy = (double)a[3 * i + 1] - b[3 * i + 1], dz = (double)a[3 * i + 2] - b[3 * i + 2];
        double d = sqrt(dx * dx + dy * dy + dz * dz);
        if (!isfinite(d)) d = INFINITY;
        if (d > worst) worst = d, *at = i;
    }
    return worst < 0.0 ? 0.0 : worst;
}

static int compare(scfr *a, scfr *b, bool json)
{
    if (a->strands != b->strands || a->verts != b->verts || a->frames != b->frames) {
        fprintf(stderr, "strandcastc: --compare: cannot compare: %s has %u strands x %u vertices, %u frames; %s has %u x %u, "
                "%u frames\n", a->path, a->strands, a->verts, a->frames, b->path, b->strands, b->verts, b->frames);
        return 1;
    }
    size_t n = (size_t)a->strands * a->verts;
    float *fa = malloc(n * 12 + 1), *fb = malloc(n * 12 + 1);
    int rc = 0;
    double worst = 0.0;
    uint32_t worst_frame = 0;
    size_t worst_at = 0;
    for (uint32_t k = 0; k < a->frames && fa && fb; k++) {
        if (fread(fa, 12, n, a->f) != n || fread(fb, 12, n, b->f) != n) {
            fprintf(stderr, "strandcastc: --compare: frame %u cannot be read\n", k);
            rc = 1;
            break;
        }
        size_t at;
        double d = frame_diff(fa, fb, n, &at);
        if (json)
            printf("{\"frame\":%u,\"max_diff\":%.9g,\"strand\":%zu,\"vertex\":%zu}\n", k, isinf(d) ? 1e308 : d,
                   at / a->verts, at % a->verts);
        else
            printf("frame %u: max difference %.6g m at strand %zu, vertex %zu\n", k, d, at / a->verts, at % a->verts);
        if (d > worst || k == 0) worst = d, worst_frame = k, worst_at = at;
    }
    if (!fa || !fb) {
        fprintf(stderr, "strandcastc: --compare: out of memory for %zu positions\n", n);
        rc = 1;
    }
    free(fa);
    free(fb);
    if (rc) return rc;
    if (json)
        printf("{\"summary\":true,\"frames\":%u,\"max_diff\":%.9g,\"frame\":%u,\"strand\":%zu,\"vertex\":%zu,\"identical\":%s}\n",
               a->frames, isinf(worst) ? 1e308 : worst, worst_frame, a->verts ? worst_at / a->verts : 0,
               a->verts ? worst_at % a->verts : 0, worst == 0.0 ? "true" : "false");
    else
        printf("%u frames of %u strands x %u vertices: largest difference %.6g m at frame %u, strand %zu, vertex %zu%s\n",
               a->frames, a->strands, a->verts, worst, worst_frame, a->verts ? worst_at / a->verts : 0,
               a->verts ? worst_at % a->verts : 0, worst == 0.0 ? " (identical)" : "");
    return 0;
}

int scen_cli_compare(int argc, char **argv)
{
    const char *files[2];
    int nfiles = 0;
    bool json = false;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            fputs(COMPARE_USAGE, stdout);
            return 0;
        }
        if (strcmp(argv[i], "--json") == 0) json = true;
        else if (argv[i][0] == '-' && argv[i][1]) {
            fprintf(stderr, "strandcastc: --compare: unknown flag %s\n%s", argv[i], COMPARE_USAGE);
            return 2;
        } else if (nfiles < 2) files[nfiles++] = argv[i];
        else {
            fprintf(stderr, "strandcastc: --compare: takes two files\n%s", COMPARE_USAGE);
            return 2;
        }
    }
    if (nfiles != 2) {
        fprintf(stderr, "strandcastc: --compare: takes two files\n%s", COMPARE_USAGE);
        return 2;
    }
    scfr a = { 0 }, b = { 0 };
    int rc = open_scfr(&a, files[0]);
    if (!rc) rc = open_scfr(&b, files[1]);
    if (!rc) rc = compare(&a, &b, json);
    if (a.f) fclose(a.f);
    if (b.f) fclose(b.f);
    return rc;
}
