/* proto: float formatting and a small text buffer for pre-rendered JSON fragments. */
#include "proto_json.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Writes the shortest %g form of f that reads back as f; returns its length. */
static int format_float(char *buf, size_t cap, float f)
{
    if (!isfinite(f)) return snprintf(buf, cap, "0");
    int n = 0;
    for (int prec = 6; prec <= 9; prec++) {
        n = snprintf(buf, cap, "%.*g", prec, (double)f);
        if ((float)strtod(buf, NULL) == f) break;
    }
    return n;
}

double proto_json_float(float f)
{
    char buf[32];
    format_float(buf, sizeof buf, f);
    return strtod(buf, NULL);
}

cJSON *proto_json_float_array(const float *v, size_t n)
{
    cJSON *arr = cJSON_CreateArray();
    for (size_t i = 0; arr && i < n; i++) {
        cJSON *x = cJSON_CreateNumber(proto_json_float(v[i]));
        if (!x || !cJSON_AddItemToArray(arr, x)) {
            cJSON_Delete(x);
            cJSON_Delete(arr);
            return NULL;
        }
    }
    return arr;
}

void proto_sb_put(proto_sb *sb, const char *s, size_t n)
{
    if (sb->failed) return;
    if (sb->len + n + 1 > sb->cap) {
        size_t cap = sb->cap ? sb->cap : 256;
        while (cap < sb->len + n + 1) cap *= 2;
        char *d = cJSON_malloc(cap);
        if (!d) {
            cJSON_free(sb->data);
            memset(sb, 0, sizeof *sb);
            sb->failed = 1;
            return;
        }
        if (sb->len) memcpy(d, sb->data, sb->len);
        cJSON_free(sb->data);
        sb->data = d;
        sb->cap = cap;
    }
    memcpy(sb->data + sb->len, s, n);
    sb->len += n;
    sb->data[sb->len] = '\0';
}

void proto_sb_floats(proto_sb *sb, const float *v, size_t n, size_t stride)
{
    proto_sb_put(sb, "[", 1);
    for (size_t i = 0; i < n; i++) {
        char buf[40];
        int w = format_float(buf + 1, sizeof buf - 1, v[i * stride]);
        buf[0] = ',';
        proto_sb_put(sb, i ? buf : buf + 1, (size_t)w + (i ? 1 : 0));
    }
    proto_sb_put(sb, "]", 1);
}

char *proto_sb_take(proto_sb *sb)
{
    char *d = sb->failed ? NULL : sb->data;
    memset(sb, 0, sizeof *sb);
    return d;
}
