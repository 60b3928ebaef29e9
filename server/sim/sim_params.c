/* sim: the parameter table (ranges from the DFTL paper, the thesis and the hair-mesh paper), defaults and validation. */
#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "sim.h"

/* The solvers a parameter applies to (core_param_info.solvers); ALL = NULL: every one. */
static const char *const dftl_only[] = { "dftl", NULL };
static const char *const pbd_only[] = { "pbd", NULL };
static const char *const strands[] = { "dftl", "pbd", NULL };
static const char *const hairmesh_only[] = { "hairmesh", NULL };
#define ALL NULL
#define DFTL dftl_only
#define PBD pbd_only
#define STRANDS strands
#define HM hairmesh_only

static const char *const solver_names[] = { "dftl", "hairmesh", "pbd" };

#define F(field, lo, hi, d, unit, help, sv) \
    { #field, CORE_PARAM_FLOAT, offsetof(sim_params, field), lo, hi, d, unit, help, CORE_PARAM_LINEAR, NULL, sv }
/* a float whose useful values span many decades: sliders use the log mapping (core/param.h) */
#define FLOG(field, lo, hi, d, unit, help, sv) \
    { #field, CORE_PARAM_FLOAT, offsetof(sim_params, field), lo, hi, d, unit, help, CORE_PARAM_LOG, NULL, sv }
#define I(field, lo, hi, d, unit, help, sv) \
    { #field, CORE_PARAM_INT, offsetof(sim_params, field), lo, hi, d, unit, help, CORE_PARAM_LINEAR, NULL, sv }
#define B(field, d, help, sv) \
    { #field, CORE_PARAM_BOOL, offsetof(sim_params, field), 0, 1, d, "", help, CORE_PARAM_LINEAR, NULL, sv }
/* the hair-mesh solver's fields (sim_params.hm.field), named hm_field in the schema */
#define HF(field, lo, hi, d, unit, help) \
    { "hm_" #field, CORE_PARAM_FLOAT, offsetof(sim_params, hm.field), lo, hi, d, unit, help, CORE_PARAM_LINEAR, NULL, HM }
#define HFLOG(field, lo, hi, d, unit, help) \
    { "hm_" #field, CORE_PARAM_FLOAT, offsetof(sim_params, hm.field), lo, hi, d, unit, help, CORE_PARAM_LOG, NULL, HM }
#define HI(field, lo, hi, d, unit, help) \
    { "hm_" #field, CORE_PARAM_INT, offsetof(sim_params, hm.field), lo, hi, d, unit, help, CORE_PARAM_LINEAR, NULL, HM }
#define HB(field, d, help) \
    { "hm_" #field, CORE_PARAM_BOOL, offsetof(sim_params, hm.field), 0, 1, d, "", help, CORE_PARAM_LINEAR, NULL, HM }
#define E(field, choices, d, help) \
    { #field, CORE_PARAM_ENUM, offsetof(sim_params, field), 0, sizeof choices / sizeof choices[0] - 1, d, "", help, \
      CORE_PARAM_LINEAR, choices, NULL }

static const core_param_info table[] = {
    E(solver, solver_names, SIM_SOLVER_DFTL, "The solver: dftl (Dynamic Follow-The-Leader with shape constraints and SPH hair-hair interaction, the default), hairmesh (the volumetric hair-mesh solver; needs a hair-mesh groom) or pbd (position-based guide strands: Verlet, distance, angular and collision constraints, thesis 3.2). Switching keeps the hair where it is. Only the active solver's parameters apply."),
    F(dt, 0.008, 0.05, 1.0 / 60.0, "s", "Simulated time per step (the paper uses 0.016 s). Stiffness and damping are per unit of time, so they mean the same at any step.", ALL),
    I(substeps, 1, SIM_MAX_SUBSTEPS, 4, "", "Solver substeps per step; roots and colliders are interpolated across them. Stiffness and damping are per unit of time, so they mean the same at any substep count.", ALL),
    F(gravity, 0.0, 50.0, 9.81, "m/s^2", "Gravity along -y.", ALL),
    F(wind_x, -50.0, 50.0, 0.0, "m/s^2", "Wind acceleration, x component.", ALL),
    F(wind_y, -50.0, 50.0, 0.0, "m/s^2", "Wind acceleration, y component.", ALL),
    F(wind_z, -50.0, 50.0, 0.0, "m/s^2", "Wind acceleration, z component.", ALL),
    F(damping, 0.0, 200.0, 30.0, "1/s", "Internal damping: the velocity of each vertex relative to the vertex before it decays at this rate (half-life ln 2 / damping). Stills jitter and whipping tips; the hair still follows the head. (The hair-mesh solver has hm_damping instead.)", STRANDS),
    F(air_drag, 0.0, 20.0, 3.0, "1/s", "Air drag: every vertex's velocity (relative to still air) decays at this rate, so hair that swings freely comes to rest; the head's motion is not damped. The hair-mesh solver takes at most 12 1/s (about critical damping of the mesh's swing about its roots: more would only slow its return to rest).", ALL),
    F(dftl_correction, 0.0, 1.0, 0.9, "", "s_d: DFTL velocity correction (paper eq. 14, about 0.9): the share of the next vertex's local-shape and inextensibility correction taken off a vertex's velocity, which hides the serial solver's mass bias. PBD: the share of the correction its closing root-to-tip length pass gave the next vertex.", STRANDS),
    FLOG(global_stiffness, 0.0, 1.0e6, 1.0e5, "1/s^2", "Pull toward the rest pose in the head frame, as a spring per unit mass: a vertex settles g / k from its target. The paper's s_g < 0.1 at 0.016 s is k < 390.", STRANDS),
    FLOG(local_stiffness, 0.0, 1.0e8, 1.0e6, "1/s^2", "Pull toward the rest shape in the frame of the vertex before, as a spring per unit mass (bending). The paper's s_l < 0.3 at 0.016 s is k < 1,170.", STRANDS),
    F(stiffness_tip, 0.0, 1.0, 0.25, "", "Both stiffnesses at the tip as a fraction of their root value (linear fade along the strand).", STRANDS),
    F(repulsion, 0.0, 0.5, 0.1, "", "SPH pressure coefficient: repulsion between strands that gives the hair volume. The pressure k (rho - rho0) acts through the stiffness that holds a vertex (60 x the shape springs' tip stiffness: the global one, or a tenth of the local one where that is weaker; a 1/60 s frame's worth with shape off) and is smoothed over about 0.09 s, so a vertex in a crowd settles outward by a distance proportional to repulsion x h x (over-density), whatever the stiffness. Up: more volume.", DFTL),
    F(viscosity, 0.0, 100.0, 10.0, "1/s", "SPH viscosity (paper eq. 15, Mueller et al. 2003): the velocity of a vertex relative to its neighbours' kernel-weighted mean decays at this rate times its neighbour weight (about 1 in a crowd), integrated exactly over a step so any value is stable: friction between strands. The velocities are the hair's motion since the last SPH evaluation, so hair at rest feels none. Damps relative motion; no effect on the settled volume or shape.", DFTL),
    F(sph_radius, 0.0, 0.05, 0.0, "m", "SPH smoothing length h. 0 = automatic: 1.75 x the groom's mean root spacing (distance from a root to the nearest other root), 3 mm on the default 4,096-strand groom, so it follows the strand count. Values below 1 mm are taken as 1 mm. Up: more volume.", DFTL),
    F(rest_density, 0.1, 10.0, 0.25, "", "SPH rest density rho0 as a multiple of the groom's mean rest-pose density; vertices denser than this push apart. Below 1 the authored pose is denser than rho0, so SPH adds volume to a style the shape springs hold (at 1 it adds almost none). Up: less volume.", DFTL),
    I(neighbor_cap, 12, SIM_MAX_NEIGHBOR_CAP, 24, "", "SPH neighbours kept per particle, nearest first. At least 12: with fewer, the nearest few switch between candidates at nearly equal distances from step to step and the pressure never lets the hair rest.", DFTL),
    B(shape, 1, "Global and local shape constraints.", STRANDS),
    B(sph, 1, "Hair-hair interaction (SPH pressure and viscosity).", DFTL),
    B(collisions, 1, "Collisions with the character's colliders.", ALL),
    F(friction, 0.0, 1.0, 0.15, "", "Contact friction (Coulomb-like, dimensionless): hair touching the character keeps still while its sliding over a substep is at most this share of how far the contact pushes it out, and slides that much less otherwise. 0 lets hair slide freely over the head; 1 holds it unless it is pulled nearly along the surface.", ALL),
    F(hair_friction, 0.0, 2.0, 0.5, "", "Hair-hair static friction (Coulomb-like, dimensionless): a vertex that the SPH pressure presses into its neighbours is held against sliding relative to them (their kernel-weighted mean motion) by a friction that builds up while it slides, up to this times its pressure's push (the pressure term x the neighbour weight x the repulsion's stiffness), and slips beyond that. Hair in a crowd then stays where it stopped instead of creeping along the pressure's neutral valleys; hair moving together feels none, and with no pressure it has no hold. 0: none.", DFTL),
    I(pbd_iterations, 1, 32, 4, "", "PBD constraint iterations per substep (distance in even/odd pairs, angular, shape, collisions), then one exact root-to-tip length pass. Up: less stretch left to that pass (whose corrections reach the velocities through dftl_correction) and stiffer-looking strands at more cost; the stiffnesses are compliances, so the settled shape does not depend on it.", PBD),
    HFLOG(stretch_stiffness, 0.0, 1.0e6, 1.0e5, "1/s^2", "Stretch (Baraff-Witkin condition a (|w_u| - 1), a (|w_v| - 1)) of the triangles of the prisms' side faces (u along the hair) and of the layer faces, per unit mass: each condition is scaled so that its most moved vertex feels this rate, as at the end of a spring. Up: less stretch under gravity."),
    HFLOG(shear_stiffness, 0.0, 1.0e6, 2.0e4, "1/s^2", "Shear (Baraff-Witkin condition a w_u . w_v) of the same triangles, per unit mass, scaled as the stretch. Up: the bundles keep their cross-section."),
    HFLOG(bend_stiffness, 0.0, 1.0e6, 2.0e4, "1/s^2", "Bend (Baraff-Witkin condition: the dihedral angle between side triangles sharing an edge, less its rest angle), per unit mass: k h1 h2 / 2 on the angle, h the triangles' heights over the edge, about this rate on the tips' displacement. Up: the hair holds its authored shape against gravity."),
    HFLOG(volume_stiffness, 0.0, 1.0e6, 2.0e4, "1/s^2", "Volume force on the eight (six) overlapping corner tetrahedra of every prism (paper eq. 1-2), per unit mass and scaled by each tetrahedron's size. Recovers the volume even from flattened or inverted tetrahedra."),
    HF(damping, 5.0, 8.0, 8.0, "1/s", "Each damper: the velocity of two neighbouring vertices (a column segment, a layer edge, a face diagonal, layers l and l + 2 of a column) relative to each other (less the head's turning) decays at this rate, along the pair and across it, so swinging and bending settle as well as stretch; each Baraff-Witkin condition damps its own rate at it too. The range is where more damping settles sooner and the hair rests within 3 s of a stop: below 5 the swinging rings longer, above 8 the soft modes are over-damped and creep back (README)."),
    HI(cg_iterations, 1, 1000, 200, "", "Most modified conjugate gradient iterations per solve (the implicit step, the deformation minimization)."),
    HFLOG(cg_tolerance, 1.0e-8, 1.0e-1, 1.0e-2, "", "CG stops once the preconditioned residual norm is below this share of the right-hand side's (the implicit step) or of its starting value (the deformation minimization)."),
    HB(deform_min, 1, "Deformation minimization after collisions (paper eq. 3-4): the other vertices follow the pushed surface so the mesh keeps its local shape and volume."),
};

const char *sim_solver_name(int32_t solver)
{
    return solver >= 0 && (size_t)solver < sizeof solver_names / sizeof solver_names[0] ? solver_names[solver] : "unknown";
}

const core_param_info *sim_param_table(size_t *count)
{
    *count = sizeof table / sizeof table[0];
    return table;
}

void sim_params_default(sim_params *p)
{
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++) {
        char *field = (char *)p + table[i].offset;
        switch (table[i].type) {
        case CORE_PARAM_FLOAT: *(float *)field = (float)table[i].def; break;
        case CORE_PARAM_INT:
        case CORE_PARAM_ENUM: *(int32_t *)field = (int32_t)table[i].def; break;
        case CORE_PARAM_BOOL: *(bool *)field = table[i].def != 0.0; break;
        }
    }
}

core_status sim_params_validate(const sim_params *p, core_err *err)
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
        case CORE_PARAM_ENUM:
            v = *(const int32_t *)field;
            if (v < t->min || v > t->max)
                return core_fail(err, CORE_EINVAL, "parameter %s: %g is not a choice (0 to %g)", t->name, v, t->max);
            continue;
        default: continue;
        }
        /* float fields are stored in single precision: allow the rounding of the bounds */
        double slack = t->type == CORE_PARAM_FLOAT ? 1e-6 * fabs(t->max - t->min) : 0.0;
        if (v < t->min - slack || v > t->max + slack)
            return core_fail(err, CORE_EINVAL, "parameter %s: %g is outside [%g, %g]", t->name, v, t->min, t->max);
    }
    return CORE_OK;
}
