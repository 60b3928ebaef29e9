/* core: strict UTF-8 validation and repair. */
#include "utf8.h"

/* The length (1..4) of the well-formed sequence at s[0, len), or 0 when there is none. */
static size_t sequence(const unsigned char *s, size_t len)
{
    unsigned c = s[0];
    if (c < 0x80) return 1;
    size_t n;
    unsigned cp, min;
    if ((c & 0xe0) == 0xc0) { n = 1; cp = c & 0x1f; min = 0x80; }
    else if ((c & 0xf0) == 0xe0) { n = 2; cp = c & 0x0f; min = 0x800; }
    else if ((c & 0xf8) == 0xf0) { n = 3; cp = c & 0x07; min = 0x10000; }
    else return 0; /* continuation byte or 0xf8.. lead */
    if (n > len - 1) return 0;
    for (size_t k = 1; k <= n; k++) {
        if ((s[k] & 0xc0) != 0x80) return 0;
        cp = (cp << 6) | (s[k] & 0x3f);
    }
    if (cp < min || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return 0;
    return n + 1;
}

bool core_utf8_valid(const void *data, size_t len)
{
    const unsigned char *s = data;
    for (size_t i = 0, n; i < len; i += n)
        if (!(n = sequence(s + i, len - i))) return false;
    return true;
}

size_t core_utf8_repair(char *s, size_t len)
{
    unsigned char *u = (unsigned char *)s;
    size_t fixed = 0;
    for (size_t i = 0; i < len;) {
        size_t n = sequence(u + i, len - i);
        if (n) {
            i += n;
            continue;
        }
        u[i++] = '?';
        fixed++;
    }
    return fixed;
}
