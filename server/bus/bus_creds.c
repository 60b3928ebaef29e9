/* bus: a NATS credentials file's shape checked before connecting (a user JWT and an NKey user seed). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bus.h"

#define CREDS_MAX (64 * 1024) /* a .creds file is about 1 KB; a JWT with many permissions a few */
#define SEED_LEN 58           /* 'S', 'U', the seed and its checksum in base32 */

/* A line (len bytes) that reads as a JWT: "eyJ" (base64url of '{"') and three base64url parts. */
static bool is_jwt(const char *p, size_t len)
{
    int dots = 0;
    for (size_t i = 0; i < len; i++) {
        char c = p[i];
        if (c == '.') dots++;
        else if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_'))
            return false;
    }
    return len > 3 && strncmp(p, "eyJ", 3) == 0 && dots == 2;
}

/* A line that reads as an NKey user seed: "SU" and base32. */
static bool is_user_seed(const char *p, size_t len)
{
    if (len != SEED_LEN || strncmp(p, "SU", 2) != 0) return false;
    for (size_t i = 0; i < len; i++)
        if (!((p[i] >= 'A' && p[i] <= 'Z') || (p[i] >= '2' && p[i] <= '7'))) return false;
    return true;
}

core_status bus_creds_check(const char *path, core_err *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) return core_fail(err, CORE_EIO, "%s", strerror(errno));
    char *buf = malloc(CREDS_MAX + 1);
    if (!buf) {
        fclose(f);
        return core_fail(err, CORE_ENOMEM, "out of memory");
    }
    size_t n = fread(buf, 1, CREDS_MAX + 1, f);
    int rerr = ferror(f) ? errno : 0;
    fclose(f);
    bool jwt = false, seed = false;
    for (size_t i = 0; i < n && n <= CREDS_MAX;) {
        size_t end = i;
        while (end < n && buf[end] != '\n' && buf[end] != '\r') end++;
        jwt = jwt || is_jwt(buf + i, end - i);
        seed = seed || is_user_seed(buf + i, end - i);
        i = end + 1;
    }
    free(buf);
    if (rerr) return core_fail(err, CORE_EIO, "%s", strerror(rerr));
    if (n > CREDS_MAX) return core_fail(err, CORE_EINVAL, "over %d bytes: not a NATS credentials file", CREDS_MAX);
    if (!jwt || !seed)
        return core_fail(err, CORE_EINVAL, "not a NATS credentials file: no %s (nsc generate creds makes one)",
                         !jwt ? "user JWT" : "NKey user seed (a line SU...)");
    return CORE_OK;
}
