/* proto: the RFC 8259 rules cJSON is lenient about: no byte-order mark, and numbers in JSON's
 * own grammar (no leading zeros, no '+', no bare '.', digits after '.' and 'e'). */
#include "proto_json.h"

static bool digit(char c) { return c >= '0' && c <= '9'; }

/* The end of the number token starting at i (a '-' or a digit) if it follows
 * -?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][+-]?[0-9]+)?, else 0 (at the byte that breaks it). */
static size_t number_end(const char *t, size_t len, size_t i, size_t *bad)
{
    if (t[i] == '-') i++;
    if (i >= len || !digit(t[i])) return *bad = i, 0;
    if (t[i] == '0') {
        i++;
        if (i < len && digit(t[i])) return *bad = i, 0; /* a leading zero */
    } else {
        while (i < len && digit(t[i])) i++;
    }
    if (i < len && t[i] == '.') {
        i++;
        if (i >= len || !digit(t[i])) return *bad = i, 0;
        while (i < len && digit(t[i])) i++;
    }
    if (i < len && (t[i] == 'e' || t[i] == 'E')) {
        i++;
        if (i < len && (t[i] == '+' || t[i] == '-')) i++;
        if (i >= len || !digit(t[i])) return *bad = i, 0;
        while (i < len && digit(t[i])) i++;
    }
    return i;
}

bool proto_json_strict(const char *t, size_t len, size_t *at, const char **why)
{
    if (len >= 3 && (unsigned char)t[0] == 0xEF && (unsigned char)t[1] == 0xBB && (unsigned char)t[2] == 0xBF) {
        *at = 0;
        *why = "a byte-order mark before the JSON text";
        return false;
    }
    bool in_str = false;
    for (size_t i = 0; i < len; i++) {
        char c = t[i];
        if (in_str) {
            if (c == '\\') i++; /* the escaped character (cJSON checks the escape itself) */
            else if (c == '"') in_str = false;
            continue;
        }
        if (c == '"') {
            in_str = true;
        } else if (c == '-' || c == '+' || c == '.' || digit(c)) {
            size_t bad = i, end = c == '+' || c == '.' ? 0 : number_end(t, len, i, &bad);
            if (!end) {
                *at = bad;
                *why = "a number outside JSON's grammar (leading zero, '+', or a '.' or exponent without digits)";
                return false;
            }
            i = end - 1;
        }
    }
    return true;
}
