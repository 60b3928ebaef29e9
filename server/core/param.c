/* core: look-ups in a parameter table entry (the index of an enum choice). */
#include <string.h>

#include "param.h"

int core_param_choice(const core_param_info *t, const char *name)
{
    if (t->type != CORE_PARAM_ENUM || !t->choices || !name) return -1;
    for (int i = 0; i <= (int)t->max; i++)
        if (strcmp(t->choices[i], name) == 0) return i;
    return -1;
}
