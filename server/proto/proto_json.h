/* proto: internal JSON helpers shared by the builders (float formatting, raw number arrays). */
#ifndef PROTO_PROTO_JSON_H
#define PROTO_PROTO_JSON_H

#include <cjson/cJSON.h>
#include <stdbool.h>
#include <stddef.h>

/* The shortest decimal that reads back as f, as a double (so 9.81f prints as 9.81). Pure. */
double proto_json_float(float f);

/* A JSON array of n floats (shortest form); NULL when out of memory. */
cJSON *proto_json_float_array(const float *v, size_t n);

/* A growable text buffer for large pre-rendered JSON fragments. */
typedef struct proto_sb {
    char *data;
    size_t len, cap;
    int failed; /* an allocation failed; data is freed and stays NULL */
} proto_sb;

/* Appends text; marks the buffer failed when out of memory. */
void proto_sb_put(proto_sb *sb, const char *s, size_t n);
/* Appends "[a,b,...]" of n floats in shortest form, every stride-th value from v. */
void proto_sb_floats(proto_sb *sb, const float *v, size_t n, size_t stride);
/* Returns the NUL-terminated text (caller frees with cJSON_free) or NULL after a failure. */
char *proto_sb_take(proto_sb *sb);

/* True when a string in the JSON text t[0, len) (already parsed as valid) holds a NUL
 * character (the escape \u0000 or a raw 0 byte); member receives the top-level member it is
 * in ("" when it is in a key or outside any member), cut to cap - 1 bytes. Pure. */
bool proto_json_nul_member(const char *t, size_t len, char *member, size_t cap);
/* True when the text t[0, len) keeps the RFC 8259 rules cJSON does not check: no byte-order
 * mark, every number in JSON's grammar (no leading zeros, '+', bare '.', or exponent without
 * digits). Otherwise false with the byte offset and a reason (static). Scans the text only;
 * whether it is valid JSON otherwise is cJSON's job. Pure. */
bool proto_json_strict(const char *t, size_t len, size_t *at, const char **why);

#endif
