/* core: a self-describing parameter table entry (name, type, range, unit, help). */
#ifndef CORE_PARAM_H
#define CORE_PARAM_H

#include <stddef.h>

/* ENUM: an int32_t field holding the index of one of `choices`; on the wire it is the choice's
 * name (a string), min is 0 and max the last index. */
typedef enum core_param_type { CORE_PARAM_FLOAT, CORE_PARAM_INT, CORE_PARAM_BOOL, CORE_PARAM_ENUM } core_param_type;

/* How a user interface should map a control over the range: a hint only, values and validation
 * are the same for both. CORE_PARAM_LOG is for float parameters whose useful values span many
 * decades: it requires min >= 0 and max > 0 (see proto/PROTOCOL.md, "Parameter scale", for the
 * slider mapping clients use). Zero is linear, so tables that omit the field keep working. */
typedef enum core_param_scale { CORE_PARAM_LINEAR = 0, CORE_PARAM_LOG } core_param_scale;

/* Describes one field of a params struct: its byte offset, type (float, int32_t, bool, or an
 * int32_t choice index), inclusive range, default, unit, one-line help, the scale hint for
 * sliders, the names of an ENUM's choices (max + 1 of them) and the solvers the field applies
 * to (NULL-terminated names of the `solver` parameter's choices; NULL = every solver). The
 * fields after help are last so that tables written without them are linear, not choices, and
 * shared by every solver. Tables of these are static const data owned by the module that
 * defines the struct (e.g. sim_param_table). */
typedef struct core_param_info {
    const char *name;
    core_param_type type;
    size_t offset;
    double min, max, def;
    const char *unit;
    const char *help;
    core_param_scale scale;
    const char *const *choices;
    const char *const *solvers;
} core_param_info;

/* The index of name among t's choices (an ENUM), or -1. Pure. */
int core_param_choice(const core_param_info *t, const char *name);

#endif
