/* net: pure text checks: comma-separated token lists. */
#include <string.h>

#include "net_internal.h"

bool net_token_listed(const char *list, const char *token)
{
    size_t tlen = strlen(token);
    const char *p = list;
    while (*p) {
        while (*p == ' ' || *p == '\t' || *p == ',') p++;
        const char *start = p;
        while (*p && *p != ',') p++;
        const char *end = p;
        while (end > start && (end[-1] == ' ' || end[-1] == '\t')) end--;
        if ((size_t)(end - start) == tlen && memcmp(start, token, tlen) == 0) return true;
    }
    return false;
}
