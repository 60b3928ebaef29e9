/* proto: room names and the room a WebSocket path addresses. */
#include <stdio.h>
#include <string.h>

#include "proto.h"

bool proto_room_valid(const char *name)
{
    size_t n = 0;
    for (; name[n]; n++) {
        char c = name[n];
        bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_';
        if (!ok || n == PROTO_MAX_ROOM) return false;
    }
    return n > 0;
}

core_status proto_room_of_path(const char *path, char *room, proto_error *e)
{
    size_t k = strlen(PROTO_ROOM_PREFIX);
    if (strncmp(path, PROTO_ROOM_PREFIX, k) != 0) {
        memcpy(room, PROTO_DEFAULT_ROOM, sizeof PROTO_DEFAULT_ROOM);
        return CORE_OK;
    }
    const char *name = path + k;
    if (!proto_room_valid(name)) {
        char shown[44]; /* printable ASCII only: the reason goes out as UTF-8 text */
        size_t n = 0;
        for (; name[n] && n < 40; n++) shown[n] = name[n] > ' ' && name[n] < 127 && name[n] != '"' ? name[n] : '?';
        strcpy(shown + n, name[n] ? "..." : "");
        return proto_fail(e, PROTO_ERR_BAD_ROOM, "room", "\"%s\" is not a room name: 1..%d letters, digits, '-' or '_' (path %sNAME)",
                          shown, PROTO_MAX_ROOM, PROTO_ROOM_PREFIX);
    }
    strcpy(room, name);
    return CORE_OK;
}

bool proto_room_path(const char *room, char *path, size_t cap)
{
    if (!room || !strcmp(room, PROTO_DEFAULT_ROOM)) return snprintf(path, cap, "/") < (int)cap;
    if (!proto_room_valid(room)) return false;
    return snprintf(path, cap, "%s%s", PROTO_ROOM_PREFIX, room) < (int)cap;
}
