/* scen: reads a scenario script (JSON) into typed steps, naming the step and field of any error. */
#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scen.h"

#define SCEN_DEFAULT_TIMEOUT_MS 10000.0
#define SCEN_MAX_SCRIPT (16u << 20)

static const char *const kind_names[] = { NULL, "send", "reply", "frames", "until_sim_time", "until_step",
                                          "sleep_ms", "expect", "check" };

/* The keys each step kind may carry besides its own ("comment" is allowed everywhere). */
static const char *const kind_keys[][8] = {
    [SCEN_SEND] = { "at_ms", "at_sim_time", "at_step", "timeout_ms" },
    [SCEN_REPLY] = { "type", "error", "field", "timeout_ms" },
    [SCEN_FRAMES] = { "timeout_ms" },
    [SCEN_UNTIL_SIM_TIME] = { "timeout_ms" },
    [SCEN_UNTIL_STEP] = { "timeout_ms" },
    [SCEN_SLEEP] = { NULL },
    [SCEN_EXPECT] = { "path", "equals", "tolerance", "min", "max", "within_ms" },
    [SCEN_CHECK] = { "timeout_ms" },
};

static const char *const check_keys[] = { "frames", "seconds", "max_stretch", "max_depth", "root_tolerance",
                                          "min_fps", "max_gap_ms" };

const char *scen_kind_name(scen_kind k)
{
    return k >= SCEN_SEND && k <= SCEN_CHECK ? kind_names[k] : "?";
}

/* Fails with "step I (KIND): field "F": WHY". */
static core_status bad(core_err *err, size_t i, scen_kind k, const char *field, const char *why)
{
    return core_fail(err, CORE_EFORMAT, "step %zu (%s): field \"%s\": %s", i, k ? scen_kind_name(k) : "?", field, why);
}

/* A number member of o in [lo, hi] into *out (unchanged when absent). */
static core_status number(const cJSON *o, const char *key, double lo, double hi, double *out, size_t i, scen_kind k,
                          core_err *err)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!v) return CORE_OK;
    if (!cJSON_IsNumber(v)) return bad(err, i, k, key, "must be a number");
    if (!isfinite(v->valuedouble)) return bad(err, i, k, key, "must be finite");
    if (v->valuedouble < lo || v->valuedouble > hi) {
        char why[96];
        snprintf(why, sizeof why, "%g is outside [%g, %g]", v->valuedouble, lo, hi);
        return bad(err, i, k, key, why);
    }
    *out = v->valuedouble;
    return CORE_OK;
}

/* A string member of o into out (cap bytes; unchanged when absent). */
static core_status string(const cJSON *o, const char *key, char *out, size_t cap, size_t i, scen_kind k, core_err *err)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, key);
    if (!v) return CORE_OK;
    if (!cJSON_IsString(v)) return bad(err, i, k, key, "must be a string");
    if (strlen(v->valuestring) >= cap) return bad(err, i, k, key, "is too long");
    snprintf(out, cap, "%s", v->valuestring);
    return CORE_OK;
}

/* True when any number in the tree is not finite (cJSON reads 1e999 as infinity). */
static bool has_non_finite(const cJSON *v)
{
    if (cJSON_IsNumber(v)) return !isfinite(v->valuedouble);
    for (const cJSON *c = v->child; c; c = c->next)
        if (has_non_finite(c)) return true;
    return false;
}

static bool key_allowed(scen_kind k, const char *key)
{
    if (strcmp(key, "comment") == 0 || strcmp(key, kind_names[k]) == 0) return true;
    for (size_t j = 0; j < 8 && kind_keys[k][j]; j++)
        if (strcmp(kind_keys[k][j], key) == 0) return true;
    return false;
}

static core_status read_check(const cJSON *o, scen_step *st, size_t i, core_err *err)
{
    if (!cJSON_IsObject(o)) return bad(err, i, SCEN_CHECK, "check", "must be an object of bounds");
    for (const cJSON *m = o->child; m; m = m->next) {
        bool known = false;
        for (size_t j = 0; j < sizeof check_keys / sizeof check_keys[0]; j++) known |= strcmp(m->string, check_keys[j]) == 0;
        if (!known) {
            char f[80];
            snprintf(f, sizeof f, "check.%.60s", m->string);
            return bad(err, i, SCEN_CHECK, f, "unknown field");
        }
    }
    core_status s;
    scen_check_desc *d = &st->check;
    if ((s = number(o, "frames", 0, 1e9, &st->count, i, SCEN_CHECK, err)) ||
        (s = number(o, "seconds", 0, 86400, &st->seconds, i, SCEN_CHECK, err)) ||
        (s = number(o, "max_stretch", -1, 1e6, &d->max_stretch, i, SCEN_CHECK, err)) ||
        (s = number(o, "max_depth", -1, 1e6, &d->max_depth, i, SCEN_CHECK, err)) ||
        (s = number(o, "root_tolerance", -1, 1e6, &d->root_tolerance, i, SCEN_CHECK, err)) ||
        (s = number(o, "min_fps", 0, 1e6, &d->min_fps, i, SCEN_CHECK, err)) ||
        (s = number(o, "max_gap_ms", -1, 1e9, &d->max_gap_ms, i, SCEN_CHECK, err)))
        return s;
    if (st->count == 0 && st->seconds == 0) return bad(err, i, SCEN_CHECK, "check", "needs \"frames\" or \"seconds\"");
    return CORE_OK;
}

static core_status read_reply_id(const cJSON *v, scen_step *st, size_t i, core_err *err)
{
    if (cJSON_IsNull(v)) {
        st->id_kind = 0;
    } else if (cJSON_IsNumber(v)) {
        if (!isfinite(v->valuedouble)) return bad(err, i, SCEN_REPLY, "reply", "must be finite");
        st->id_kind = 1;
        st->id_num = v->valuedouble;
    } else if (cJSON_IsString(v)) {
        if (strlen(v->valuestring) > 64) return bad(err, i, SCEN_REPLY, "reply", "an id is at most 64 bytes");
        st->id_kind = 2;
        snprintf(st->id_str, sizeof st->id_str, "%s", v->valuestring);
    } else {
        return bad(err, i, SCEN_REPLY, "reply", "must be the request id (a number or a string) or null");
    }
    return CORE_OK;
}

/* Reads step i (object o) into st. */
static core_status read_step(const cJSON *o, scen_step *st, size_t i, double timeout_ms, core_err *err)
{
    if (!cJSON_IsObject(o)) return core_fail(err, CORE_EFORMAT, "step %zu: must be an object", i);
    scen_kind k = 0;
    for (int j = SCEN_SEND; j <= SCEN_CHECK; j++) {
        if (!cJSON_GetObjectItemCaseSensitive(o, kind_names[j])) continue;
        if (k) return core_fail(err, CORE_EFORMAT, "step %zu: names two kinds, \"%s\" and \"%s\"", i, kind_names[k], kind_names[j]);
        k = (scen_kind)j;
    }
    if (!k) {
        return core_fail(err, CORE_EFORMAT,
                         "step %zu: unknown step kind (fields: %s%s); a step has one of send, reply, frames, "
                         "until_sim_time, until_step, sleep_ms, expect, check",
                         i, o->child ? o->child->string : "none", o->child && o->child->next ? ", ..." : "");
    }
    for (const cJSON *m = o->child; m; m = m->next)
        if (!key_allowed(k, m->string)) return bad(err, i, k, m->string, "unknown field for this step kind");
    const cJSON *comment = cJSON_GetObjectItemCaseSensitive(o, "comment");
    if (comment && !cJSON_IsString(comment)) return bad(err, i, k, "comment", "must be a string");
    st->kind = k;
    st->at_ms = st->at_sim_time = st->at_step = -1.0;
    st->min = st->max = NAN;
    st->timeout_ms = timeout_ms;
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(o, kind_names[k]);
    core_status s = number(o, "timeout_ms", 0, 1e9, &st->timeout_ms, i, k, err);
    if (s) return s;
    switch (k) {
    case SCEN_SEND: {
        if (!cJSON_IsObject(v) && !cJSON_IsString(v))
            return bad(err, i, k, "send", "must be a message object (or a string sent as it is)");
        st->text = cJSON_IsString(v) ? strdup(v->valuestring) : cJSON_PrintUnformatted(v);
        if (!st->text) return core_fail(err, CORE_ENOMEM, "step %zu: out of memory", i);
        if ((s = number(o, "at_ms", 0, 1e9, &st->at_ms, i, k, err)) ||
            (s = number(o, "at_sim_time", 0, 1e9, &st->at_sim_time, i, k, err)) ||
            (s = number(o, "at_step", 0, 1e15, &st->at_step, i, k, err)))
            return s;
        if ((st->at_ms >= 0) + (st->at_sim_time >= 0) + (st->at_step >= 0) > 1)
            return bad(err, i, k, "at_ms", "give at most one of at_ms, at_sim_time and at_step");
        return CORE_OK;
    }
    case SCEN_REPLY:
        if ((s = read_reply_id(v, st, i, err)) || (s = string(o, "type", st->reply_type, sizeof st->reply_type, i, k, err)) ||
            (s = string(o, "error", st->error, sizeof st->error, i, k, err)) ||
            (s = string(o, "field", st->field, sizeof st->field, i, k, err)))
            return s;
        st->field_given = cJSON_GetObjectItemCaseSensitive(o, "field") != NULL;
        if (st->field_given && !st->error[0]) return bad(err, i, k, "field", "goes with \"error\"");
        if (st->error[0] && st->reply_type[0] && strcmp(st->reply_type, "error") != 0)
            return bad(err, i, k, "type", "an expected error is of type \"error\"");
        return CORE_OK;
    case SCEN_FRAMES:
    case SCEN_UNTIL_SIM_TIME:
    case SCEN_UNTIL_STEP:
    case SCEN_SLEEP:
        if (!cJSON_IsNumber(v)) return bad(err, i, k, kind_names[k], "must be a number");
        if (!isfinite(v->valuedouble) || v->valuedouble < 0 || v->valuedouble > 1e15)
            return bad(err, i, k, kind_names[k], "must be a finite number >= 0");
        st->count = v->valuedouble;
        if (k == SCEN_FRAMES && st->count != floor(st->count)) return bad(err, i, k, "frames", "must be a whole number");
        return CORE_OK;
    case SCEN_EXPECT: {
        if (!cJSON_IsString(v) || (strcmp(v->valuestring, "hello") && strcmp(v->valuestring, "params") &&
                                   strcmp(v->valuestring, "state") && strcmp(v->valuestring, "groom") &&
                                   strcmp(v->valuestring, "frame") && strcmp(v->valuestring, "metrics")))
            return bad(err, i, k, "expect",
                       "must be \"hello\", \"params\", \"state\", \"groom\", \"frame\" or \"metrics\"");
        snprintf(st->what, sizeof st->what, "%s", v->valuestring);
        if (!cJSON_GetObjectItemCaseSensitive(o, "path")) return bad(err, i, k, "path", "is required");
        st->tolerance = 0.0;
        st->timeout_ms = 0.0;
        if ((s = string(o, "path", st->path, sizeof st->path, i, k, err)) ||
            (s = number(o, "tolerance", 0, 1e300, &st->tolerance, i, k, err)) ||
            (s = number(o, "min", -1e300, 1e300, &st->min, i, k, err)) ||
            (s = number(o, "max", -1e300, 1e300, &st->max, i, k, err)) ||
            (s = number(o, "within_ms", 0, 1e9, &st->timeout_ms, i, k, err)))
            return s;
        const cJSON *eq = cJSON_GetObjectItemCaseSensitive(o, "equals");
        if (eq) {
            if (has_non_finite(eq)) return bad(err, i, k, "equals", "must be finite");
            st->equals = cJSON_PrintUnformatted(eq);
            if (!st->equals) return core_fail(err, CORE_ENOMEM, "step %zu: out of memory", i);
        }
        if (!eq && isnan(st->min) && isnan(st->max)) return bad(err, i, k, "equals", "give equals, min or max");
        return CORE_OK;
    }
    case SCEN_CHECK: return read_check(v, st, i, err);
    }
    return CORE_OK;
}

void scen_script_free(scen_script *s)
{
    for (size_t i = 0; i < s->nsteps; i++) {
        free(s->steps[i].text);
        free(s->steps[i].equals);
    }
    free(s->steps);
    memset(s, 0, sizeof *s);
}

core_status scen_script_parse(scen_script *s, const char *text, size_t len, core_err *err)
{
    memset(s, 0, sizeof *s);
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, len, &end, false);
    if (!root) {
        size_t at = end ? (size_t)(end - text) : 0;
        size_t line = 1;
        for (size_t j = 0; j < at && j < len; j++) line += text[j] == '\n';
        return core_fail(err, CORE_EFORMAT, "not valid JSON (line %zu, byte %zu)", line, at);
    }
    core_status st = CORE_OK;
    const cJSON *steps = cJSON_GetObjectItemCaseSensitive(root, "steps");
    double timeout_ms = SCEN_DEFAULT_TIMEOUT_MS;
    if (!cJSON_IsObject(root)) {
        st = core_fail(err, CORE_EFORMAT, "the script must be a JSON object with \"steps\"");
        goto out;
    }
    for (const cJSON *m = root->child; m; m = m->next)
        if (strcmp(m->string, "name") && strcmp(m->string, "steps") && strcmp(m->string, "timeout_ms") &&
            strcmp(m->string, "comment")) {
            st = core_fail(err, CORE_EFORMAT, "script: field \"%.64s\": unknown (name, comment, timeout_ms, steps)", m->string);
            goto out;
        }
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(root, "name");
    const cJSON *to = cJSON_GetObjectItemCaseSensitive(root, "timeout_ms");
    if (name && !cJSON_IsString(name)) {
        st = core_fail(err, CORE_EFORMAT, "script: field \"name\": must be a string");
        goto out;
    }
    if (to && (!cJSON_IsNumber(to) || !isfinite(to->valuedouble) || to->valuedouble < 0 || to->valuedouble > 1e9)) {
        st = core_fail(err, CORE_EFORMAT, "script: field \"timeout_ms\": must be a finite number in [0, 1e9]");
        goto out;
    }
    if (to) timeout_ms = to->valuedouble;
    snprintf(s->name, sizeof s->name, "%s", name ? name->valuestring : "");
    int n = cJSON_GetArraySize(steps);
    if (!cJSON_IsArray(steps) || n == 0) {
        st = core_fail(err, CORE_EFORMAT, "script: field \"steps\": must be a non-empty array of steps");
        goto out;
    }
    s->steps = calloc((size_t)n, sizeof *s->steps);
    if (!s->steps) {
        st = core_fail(err, CORE_ENOMEM, "out of memory for %d steps", n);
        goto out;
    }
    for (const cJSON *o = steps->child; o && st == CORE_OK; o = o->next) {
        st = read_step(o, &s->steps[s->nsteps], s->nsteps, timeout_ms, err);
        s->nsteps++;
    }
out:
    cJSON_Delete(root);
    if (st != CORE_OK) scen_script_free(s);
    return st;
}

core_status scen_script_load(scen_script *s, const char *path, core_err *err)
{
    memset(s, 0, sizeof *s);
    FILE *fp = fopen(path, "rb");
    if (!fp) return core_fail(err, CORE_EIO, "cannot open: %s", strerror(errno));
    char *buf = malloc(SCEN_MAX_SCRIPT + 1);
    size_t n = buf ? fread(buf, 1, SCEN_MAX_SCRIPT + 1, fp) : 0;
    bool read_error = ferror(fp) != 0;
    fclose(fp);
    if (!buf) return core_fail(err, CORE_ENOMEM, "out of memory reading it");
    core_status st;
    if (read_error) st = core_fail(err, CORE_EIO, "read error");
    else if (n > SCEN_MAX_SCRIPT) st = core_fail(err, CORE_EFORMAT, "over 16 MiB");
    else st = scen_script_parse(s, buf, n, err);
    free(buf);
    return st;
}
