/* scen: invariants on decoded frames: finite positions, segment lengths near the rest lengths,
 * no vertex deep inside an analytic collider, roots on the head transform, frame rate and gaps. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "scen.h"

#define SQRT3 1.7320508075688772

static const char *const inv_names[SCEN_INV_COUNT] = { "finite", "stretch", "depth", "root" };

void scen_check_begin(scen_check *c, const scen_check_desc *d)
{
    memset(c, 0, sizeof *c);
    if (d) c->d = *d;
    if (c->d.max_stretch == 0) c->d.max_stretch = 0.02;
    if (c->d.max_depth == 0) c->d.max_depth = 0.002;
    if (c->d.root_tolerance == 0) c->d.root_tolerance = 0.001;
    if (c->d.max_gap_ms == 0) c->d.max_gap_ms = 1000.0;
}

/* A measured value against its limit: kept when it exceeds the worst margin so far. Returns
 * whether it is a violation. */
static bool measure(scen_check_worst *wst, const codec_frame_info *info, uint32_t strand, uint32_t vertex, double value,
                    double limit, const char *what)
{
    bool worse = !wst->any || value - limit > wst->value - wst->limit;
    if (worse) {
        wst->any = true;
        wst->seq = info->seq;
        wst->strand = strand;
        wst->vertex = vertex;
        wst->value = value;
        wst->limit = limit;
        snprintf(wst->what, sizeof wst->what, "%s", what);
    }
    return !(value <= limit);
}

/* Neither a violation nor worse than the worst so far (so not worth describing). */
static bool unremarkable(const scen_check_worst *wst, double value, double limit)
{
    return value <= limit && wst->any && value - limit <= wst->value - wst->limit;
}

static core_vec3 vertex_at(const float *xyz, const codec_frame_info *info, uint32_t k, uint32_t v)
{
    const float *p = xyz + 3 * ((size_t)k * info->nverts + v);
    return core_v3(p[0], p[1], p[2]);
}

/* Depth of head-frame point p inside collider o (0 outside; for an ellipsoid a lower bound:
 * (1 - k) times the smallest semi-axis, k its scaled radius, as kE + (1-k)B(r_min) lies in E). */
static double depth_in(const scen_collider *o, core_vec3 p)
{
    double d[3] = { p.x - o->c[0], p.y - o->c[1], p.z - o->c[2] };
    switch (o->kind) {
    case SCEN_SPHERE: return o->radius - sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    case SCEN_CAPSULE: {
        double ab[3] = { o->b[0] - o->c[0], o->b[1] - o->c[1], o->b[2] - o->c[2] };
        double l2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
        double t = l2 > 0 ? (d[0] * ab[0] + d[1] * ab[1] + d[2] * ab[2]) / l2 : 0.0;
        t = t < 0 ? 0 : t > 1 ? 1 : t;
        double e[3] = { d[0] - t * ab[0], d[1] - t * ab[1], d[2] - t * ab[2] };
        return o->radius - sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    }
    case SCEN_ELLIPSOID: {
        core_vec3 l = core_q_rotate(core_q_conj(o->rot), core_v3((float)d[0], (float)d[1], (float)d[2]));
        double s[3] = { l.x / o->radii[0], l.y / o->radii[1], l.z / o->radii[2] };
        double k = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
        double rmin = fmin(o->radii[0], fmin(o->radii[1], o->radii[2]));
        return (1.0 - k) * rmin;
    }
    }
    return 0.0;
}

static const char *collider_name(scen_collider_kind k)
{
    return k == SCEN_SPHERE ? "sphere" : k == SCEN_CAPSULE ? "capsule" : "ellipsoid";
}

/* The worst distance between a root and its rest root under head; whether it is within tol. */
static bool check_roots(scen_check *c, const scen_world *w, const codec_frame_info *info, const float *xyz,
                        core_xform head, double tol)
{
    double worst = 0;
    uint32_t ws = 0;
    for (uint32_t k = 0; k < info->nstrands_sent; k++) {
        uint32_t s = k * info->stride;
        const float *r = w->roots + 3 * (size_t)s;
        core_vec3 want = core_xform_point(head, core_v3(r[0], r[1], r[2]));
        double dist = core_v3_len(core_v3_sub(vertex_at(xyz, info, k, 0), want));
        if (!(dist <= worst)) {
            worst = dist;
            ws = s;
        }
    }
    char what[96];
    snprintf(what, sizeof what, "root %.3f mm from the head-transformed rest root", worst * 1e3);
    return !measure(&c->worst[SCEN_INV_ROOT], info, ws, 0, worst, tol, what);
}

void scen_check_frame(scen_check *c, const scen_world *w, const codec_frame_info *info, const float *xyz,
                      unsigned long long arrival_ns)
{
    if (c->frames == 0) c->first_ns = arrival_ns;
    else if (arrival_ns - c->last_ns > c->max_gap_ns) {
        c->max_gap_ns = arrival_ns - c->last_ns;
        c->max_gap_seq = info->seq;
    }
    c->last_ns = arrival_ns;
    c->frames++;
    bool failed[SCEN_INV_COUNT] = { false };
    size_t n = (size_t)info->nstrands_sent * info->nverts;
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(xyz[i])) {
            size_t vi = i / 3;
            measure(&c->worst[SCEN_INV_FINITE], info, (uint32_t)(vi / info->nverts) * info->stride,
                    (uint32_t)(vi % info->nverts), xyz[i], 0, "a coordinate is not finite");
            failed[SCEN_INV_FINITE] = true;
            break;
        }
    bool same_groom = info->nstrands_total == w->strands && info->nverts == w->verts && info->stride >= 1 && w->rest_lengths;
    if (!same_groom) c->groom_unchecked++;
    double err = info->max_error_m;
    if (same_groom && c->d.max_stretch >= 0) {
        for (uint32_t k = 0; k < info->nstrands_sent; k++) {
            uint32_t s = k * info->stride;
            double rest = w->rest_lengths[s];
            if (!(rest > 0)) continue;
            double limit = c->d.max_stretch + 2.0 * SQRT3 * err / rest;
            core_vec3 prev = vertex_at(xyz, info, k, 0);
            for (uint32_t v = 1; v < info->nverts; v++) {
                core_vec3 p = vertex_at(xyz, info, k, v);
                double len = core_v3_len(core_v3_sub(p, prev));
                double rel = fabs(len - rest) / rest;
                prev = p;
                if (unremarkable(&c->worst[SCEN_INV_STRETCH], rel, limit)) continue;
                char what[96];
                snprintf(what, sizeof what, "segment %.3f mm, rest %.3f mm", len * 1e3, rest * 1e3);
                failed[SCEN_INV_STRETCH] |= measure(&c->worst[SCEN_INV_STRETCH], info, s, v, rel, limit, what);
            }
        }
    }
    core_xform head = scen_world_head(info);
    if (same_groom && c->d.root_tolerance >= 0)
        failed[SCEN_INV_ROOT] = !check_roots(c, w, info, xyz, head, c->d.root_tolerance + SQRT3 * err);
    if (c->d.max_depth >= 0 && w->ncolliders > 0 && scen_world_collisions_on(w)) {
        core_quat inv = core_q_conj(head.rot);
        double limit = c->d.max_depth + SQRT3 * err;
        for (uint32_t k = 0; k < info->nstrands_sent; k++)
            for (uint32_t v = 1; v < info->nverts; v++) {
                core_vec3 p = core_q_rotate(inv, core_v3_sub(vertex_at(xyz, info, k, v), head.pos));
                for (int o = 0; o < w->ncolliders; o++) {
                    double d = depth_in(&w->colliders[o], p);
                    if (d <= 0 || unremarkable(&c->worst[SCEN_INV_DEPTH], d, limit)) continue;
                    char what[96];
                    snprintf(what, sizeof what, "%.3f mm inside %s %d", d * 1e3, collider_name(w->colliders[o].kind), o);
                    failed[SCEN_INV_DEPTH] |= measure(&c->worst[SCEN_INV_DEPTH], info, k * info->stride, v, d, limit, what);
                }
            }
    } else if (c->d.max_depth >= 0 && w->ncolliders > 0) {
        c->depth_unchecked++;
    }
    for (int i = 0; i < SCEN_INV_COUNT; i++) c->worst[i].frames_failed += failed[i];
}

bool scen_check_fps_ok(const scen_check *c, double *fps)
{
    double secs = (double)(c->last_ns - c->first_ns) / 1e9;
    *fps = c->frames > 1 && secs > 0 ? (double)(c->frames - 1) / secs : 0.0;
    return c->d.min_fps <= 0 || *fps >= c->d.min_fps;
}

static bool gap_ok(const scen_check *c) { return c->d.max_gap_ms < 0 || (double)c->max_gap_ns / 1e6 <= c->d.max_gap_ms; }

bool scen_check_end(const scen_check *c, FILE *fp, const char *prefix)
{
    bool ok = true;
    for (int i = 0; i < SCEN_INV_COUNT; i++) {
        const scen_check_worst *wst = &c->worst[i];
        if (!wst->frames_failed) continue;
        ok = false;
        if (fp)
            fprintf(fp, "%s%s: %lu of %lu frames fail; worst: frame seq %llu, strand %u, vertex %u: %s (%.6g against %.6g)\n",
                    prefix, inv_names[i], wst->frames_failed, c->frames, (unsigned long long)wst->seq, wst->strand,
                    wst->vertex, wst->what, wst->value, wst->limit);
    }
    double fps;
    if (!scen_check_fps_ok(c, &fps)) {
        ok = false;
        if (fp) fprintf(fp, "%sframe rate: %.2f frames/s over %lu frames, want at least %g\n", prefix, fps, c->frames, c->d.min_fps);
    }
    if (!gap_ok(c)) {
        ok = false;
        if (fp)
            fprintf(fp, "%sgap: %.1f ms before frame seq %llu, want at most %g ms\n", prefix, (double)c->max_gap_ns / 1e6,
                    (unsigned long long)c->max_gap_seq, c->d.max_gap_ms);
    }
    return ok;
}

void scen_check_json(const scen_check *c, char *out, size_t cap)
{
    double fps;
    scen_check_fps_ok(c, &fps);
    int n = snprintf(out, cap, "\"frames\":%lu,\"fps\":%.3f,\"max_gap_ms\":%.3f,\"groom_unchecked\":%lu,\"depth_unchecked\":%lu",
                     c->frames, fps, (double)c->max_gap_ns / 1e6, c->groom_unchecked, c->depth_unchecked);
    for (int i = 0; i < SCEN_INV_COUNT && n > 0 && (size_t)n < cap; i++) {
        const scen_check_worst *wst = &c->worst[i];
        if (!wst->any) continue;
        n += snprintf(out + n, cap - (size_t)n,
                      ",\"%s\":{\"frames_failed\":%lu,\"seq\":%llu,\"strand\":%u,\"vertex\":%u,\"value\":%.6g,\"limit\":%.6g}",
                      inv_names[i], wst->frames_failed, (unsigned long long)wst->seq, wst->strand, wst->vertex,
                      isfinite(wst->value) ? wst->value : 0.0, wst->limit);
    }
}
