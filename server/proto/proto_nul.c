/* proto: finds NUL characters inside JSON strings (which C strings would silently cut short). */
#include <stdio.h>
#include <string.h>

#include "proto_json.h"

static bool is_nul_escape(const char *t, size_t len, size_t i)
{
    return i + 5 < len && t[i + 1] == 'u' && memcmp(t + i + 2, "0000", 4) == 0;
}

bool proto_json_nul_member(const char *t, size_t len, char *member, size_t cap)
{
    int depth = 0;
    bool in_str = false, nul = false;
    size_t start = 0, key = 0, key_len = 0;
    bool have_key = false;
    for (size_t i = 0; i < len; i++) {
        char c = t[i];
        if (!in_str) {
            if (c == '"') {
                in_str = true;
                nul = false;
                start = i + 1;
            } else if (c == '{' || c == '[') {
                depth++;
            } else if (c == '}' || c == ']') {
                depth--;
            }
            continue;
        }
        if (c == '\\') {
            if (is_nul_escape(t, len, i)) nul = true;
            i++; /* the escaped character (a \u's hex digits are plain characters) */
            continue;
        }
        if (c == '\0') nul = true;
        if (c != '"') continue;
        in_str = false;
        size_t j = i + 1;
        while (j < len && (t[j] == ' ' || t[j] == '\t' || t[j] == '\r' || t[j] == '\n')) j++;
        bool is_key = j < len && t[j] == ':';
        if (is_key && depth == 1) {
            key = start;
            key_len = i - start;
            have_key = true;
        }
        if (nul) {
            if (cap) snprintf(member, cap, "%.*s", (is_key && depth == 1) || !have_key || depth < 1 ? 0 : (int)key_len, t + key);
            return true;
        }
    }
    return false;
}
