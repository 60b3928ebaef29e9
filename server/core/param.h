/* core: a self-describing parameter table entry (name, type, range, unit, help). */
#ifndef CORE_PARAM_H
#define CORE_PARAM_H

#include <stddef.h>

typedef enum core_param_type { CORE_PARAM_FLOAT, CORE_PARAM_INT, CORE_PARAM_BOOL } core_param_type;

/* How a user interface should map a control over the range: a hint only, values and validation
 * are the same for both. CORE_PARAM_LOG is for float parameters whose useful values span many
 * decades: it requires min >= 0 and max > 0 (see proto/PROTOCOL.md, "Parameter scale", for the
 * slider mapping clients use). Zero is linear, so tables that omit the field keep working. */
typedef enum core_param_scale { CORE_PARAM_LINEAR = 0, CORE_PARAM_LOG } core_param_scale;

/* Describes one field of a params struct: its byte offset, type (float, int32_t or bool),
 * inclusive range, default, unit, one-line help and the scale hint for sliders (last, so that
 * tables written without it are linear). Tables of these are static const data
 * owned by the module that defines the struct (e.g. sim_param_table). */
typedef struct core_param_info {
    const char *name;
    core_param_type type;
    size_t offset;
    double min, max, def;
    const char *unit;
    const char *help;
    core_param_scale scale;
} core_param_info;

#endif
