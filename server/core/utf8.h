/* core: strict UTF-8: validating received text, repairing text cut at a byte count. */
#ifndef CORE_UTF8_H
#define CORE_UTF8_H

#include <stdbool.h>
#include <stddef.h>

/* True when data[0, len) is well-formed UTF-8 (no overlongs, surrogates, code points over
 * U+10FFFF or truncated sequences; NUL bytes are valid). Pure, any thread. */
bool core_utf8_valid(const void *data, size_t len);

/* Replaces, in place, every byte of s[0, len) that does not begin or belong to a well-formed
 * sequence with '?' (so that text cut at a byte count, e.g. by "%.64s", stays valid UTF-8;
 * ASCII bytes are never touched). Returns the number of bytes replaced. Pure, any thread. */
size_t core_utf8_repair(char *s, size_t len);

#endif
