/* app: the parser of client messages this binary serves: the simulation's parameter table, the
 * animation presets and the procedural groom styles (static, so a node and an edge relay judge a
 * message alike). Any thread. */
#ifndef APP_PARSER_H
#define APP_PARSER_H

#include "proto/proto.h"

/* Fills *out with the static tables (the caller keeps nothing else); CORE_EINVAL when the
 * parameter table is larger than proto serves. */
core_status app_parser_init(proto_parser *out, core_err *err);

#endif
