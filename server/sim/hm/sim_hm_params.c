/* sim_hm: the hair-mesh solver's parameter table, defaults and validation. */
#include <math.h>
#include <stddef.h>

#include "sim_hm.h"

#define F(field, lo, hi, d, unit, help) \
    { #field, CORE_PARAM_FLOAT, offsetof(sim_hm_params, field), lo, hi, d, unit, help, CORE_PARAM_LINEAR, NULL, NULL }
#define FLOG(field, lo, hi, d, unit, help) \
    { #field, CORE_PARAM_FLOAT, offsetof(sim_hm_params, field), lo, hi, d, unit, help, CORE_PARAM_LOG, NULL, NULL }
#define I(field, lo, hi, d, unit, help) \
    { #field, CORE_PARAM_INT, offsetof(sim_hm_params, field), lo, hi, d, unit, help, CORE_PARAM_LINEAR, NULL, NULL }
#define B(field, d, help) \
    { #field, CORE_PARAM_BOOL, offsetof(sim_hm_params, field), 0, 1, d, "", help, CORE_PARAM_LINEAR, NULL, NULL }

static const core_param_info table[] = {
    FLOG(stretch_stiffness, 0.0, 1.0e6, 1.0e5, "1/s^2", "Stretch (Baraff-Witkin condition |x_i - x_j| - L): springs along the hair mesh's columns and its layers' edges, per unit mass. Up: less stretch under gravity."),
    FLOG(shear_stiffness, 0.0, 1.0e6, 2.0e4, "1/s^2", "Shear: springs along the diagonals of the prisms' side faces and of the quads, per unit mass. Up: the bundles keep their cross-section."),
    FLOG(bend_stiffness, 0.0, 1.0e6, 2.0e4, "1/s^2", "Bend: springs between layers l and l + 2 of each column, per unit mass. Up: the hair holds its authored shape against gravity."),
    FLOG(volume_stiffness, 0.0, 1.0e6, 2.0e4, "1/s^2", "Volume force on the eight (six) overlapping corner tetrahedra of every prism (paper eq. 1-2), per unit mass and scaled by each tetrahedron's size. Recovers the volume even from flattened or inverted tetrahedra."),
    F(damping, 0.0, 100.0, 4.0, "1/s", "Each spring's damper: the relative velocity of its two ends along it decays at this rate."),
    I(cg_iterations, 1, 1000, 200, "", "Most modified conjugate gradient iterations per solve (the implicit step, the deformation minimization)."),
    FLOG(cg_tolerance, 1.0e-8, 1.0e-1, 1.0e-2, "", "CG stops once the preconditioned residual norm is below this share of its starting value."),
    B(deform_min, 1, "Deformation minimization after collisions (paper eq. 3-4): the other vertices follow the pushed surface so the mesh keeps its local shape and volume."),
};

const core_param_info *sim_hm_param_table(size_t *count)
{
    *count = sizeof table / sizeof table[0];
    return table;
}

void sim_hm_params_default(sim_hm_params *p)
{
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++) {
        char *field = (char *)p + table[i].offset;
        switch (table[i].type) {
        case CORE_PARAM_FLOAT: *(float *)field = (float)table[i].def; break;
        case CORE_PARAM_INT: *(int32_t *)field = (int32_t)table[i].def; break;
        case CORE_PARAM_BOOL: *(bool *)field = table[i].def != 0.0; break;
        case CORE_PARAM_ENUM: *(int32_t *)field = (int32_t)table[i].def; break;
        }
    }
}

core_status sim_hm_params_validate(const sim_hm_params *p, core_err *err)
{
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++) {
        const core_param_info *t = &table[i];
        const char *field = (const char *)p + t->offset;
        double v;
        switch (t->type) {
        case CORE_PARAM_FLOAT:
            v = *(const float *)field;
            if (!isfinite(v)) return core_fail(err, CORE_EINVAL, "parameter %s: value is not finite", t->name);
            break;
        case CORE_PARAM_INT: v = *(const int32_t *)field; break;
        default: continue;
        }
        double slack = t->type == CORE_PARAM_FLOAT ? 1e-6 * fabs(t->max - t->min) : 0.0;
        if (v < t->min - slack || v > t->max + slack)
            return core_fail(err, CORE_EINVAL, "parameter %s: %g is outside [%g, %g]", t->name, v, t->min, t->max);
    }
    return CORE_OK;
}
