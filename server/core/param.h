/* core: a self-describing parameter table entry (name, type, range, unit, help). */
#ifndef CORE_PARAM_H
#define CORE_PARAM_H

#include <stddef.h>

typedef enum core_param_type { CORE_PARAM_FLOAT, CORE_PARAM_INT, CORE_PARAM_BOOL } core_param_type;

/* Describes one field of a params struct: its byte offset, type (float, int32_t or bool),
 * inclusive range, default, unit and one-line help. Tables of these are static const data
 * owned by the module that defines the struct (e.g. sim_param_table). */
typedef struct core_param_info {
    const char *name;
    core_param_type type;
    size_t offset;
    double min, max, def;
    const char *unit;
    const char *help;
} core_param_info;

#endif
