/* sim: limits and fixed solver constants shared by the C backend and the GLSL shaders (glslc -I).
 * Only #define lines and comments, so that both languages can include it. */
#ifndef SIM_SIM_LIMITS_H
#define SIM_SIM_LIMITS_H

/* Most substeps per step (the parameter table's maximum; the frame holds one head per substep). */
#define SIM_MAX_SUBSTEPS 8
/* Most character colliders (equal to CORE_MAX_COLLIDERS, checked in sim_step.c). */
#define SIM_MAX_COLLIDERS 32
/* The largest neighbor_cap the parameter table accepts (backends size buffers by it). */
#define SIM_MAX_NEIGHBOR_CAP 64
/* Strands solved together: a CPU task and a Vulkan workgroup; collider culling is per chunk. */
#define SIM_CHUNK 64
/* The shape springs' own damping, as a substep length: a spring of stiffness k carries a
 * stiffness-proportional damper k b (toward the motion of its target's frame), with
 * b = (max(this - h, 0) + max(SIM_FTL_DAMPING_STEP - h, 0)) / 2 at substep h
 * (sim_step_shape_damping). The implicit step of a spring damps like a damper k h, a damping
 * that falls with the substep: shorter substeps left the stiff tips of a groom fluttering and
 * decayed more slowly. The first half of b (this, 1/120 s) makes up half of what a shorter
 * substep lacks; below SIM_FTL_DAMPING_STEP the second makes up the rest, so h + b and with it
 * the springs' damping per unit of time are the same at any substep up to the defaults' 1/240 s
 * (whose damping is unchanged). */
#define SIM_SHAPE_DAMPING_STEP 0.00833333333333333333
/* The length projection's damping, as a substep length: putting a vertex back onto its segment
 * length scales the displacement across the segment by L / len, so its velocity loses the share
 * delta / len (delta = len - L) per substep, a damping that falls with the substep (delta grows
 * as its square). A vertex's velocity relative to its parent loses that share times
 * (this / h - 1) more, so the projection damps the same per unit of time at any substep up to
 * this one. The default frame's substep (1/60 s in 4, 1/240 s), not SIM_SHAPE_DAMPING_STEP:
 * the defaults the rest and shape tests are tuned at keep their damping, and the shorter
 * substeps of more substeps per frame get what they lack. */
#define SIM_FTL_DAMPING_STEP 0.00416666666666666667
/* Contact rounds per vertex and level: push out of the colliders (vertex, then the segment's
 * midpoint), then the rest-length projection sliding along the contact's tangent plane. */
#define SIM_COLLISION_ITERATIONS 3
/* Distance a vertex is kept above a mesh's distance grid (metres), so hair sits on the surface. */
#define SIM_SDF_SKIN 0.00025
/* The PBD solver's stretch sum (sim_stats.pbd_stretch_mean): each strand's sum over its
 * segments of the relative stretch the iterations left, capped at SIM_PBD_STRETCH_CAP, is added
 * per substep as an integer of SIM_PBD_STRETCH_UNIT per unit, so that the C and Vulkan sums are
 * the same whatever order the strands come in. */
#define SIM_PBD_STRETCH_UNIT 1048576.0
#define SIM_PBD_STRETCH_CAP 4000.0
/* Most samples of a groom's distance grid the solvers accept (64 MiB of floats). */
#define SIM_SDF_MAX_SAMPLES 16777216
/* SPH accelerations use dimensionless kernels. The pressure term becomes an acceleration
 * through the stiffness that holds a vertex (sim_step.c): this floor, (1/60 s)^-2, the spring
 * a free vertex is held by over one reference frame, plus SIM_SPH_HOLD_GAIN x the shape
 * constraints' tip stiffness when shape is on: global_stiffness x stiffness_tip, but at most
 * SIM_SPH_HOLD_LOCAL_SHARE x local_stiffness x stiffness_tip. The bending springs' damper is
 * what damps the smoothed pressure loop: with them weaker than that (Ratboy's mohawk at
 * local_stiffness 0 under shake) strands in a crowd swing against each other for ever
 * (0.14 mm per frame 3 s after the motion; 0.0001 with the cap). A vertex in
 * a crowd then settles about repulsion x h x (pressure term) x SIM_SPH_HOLD_GAIN / 4 from
 * where the shape springs hold it, whatever their stiffness: at the defaults about 5% more
 * distance between neighbouring strands than the authored groom has (tests/test_sim_volume.c). */
#define SIM_SPH_ACCEL_SCALE 3600.0
#define SIM_SPH_HOLD_GAIN 60.0
#define SIM_SPH_HOLD_LOCAL_SHARE 0.1
/* Time constant (s) of the low-pass on the SPH acceleration: each step keeps
 * exp(-dt / SIM_SPH_SMOOTH_TIME) of the previous step's and takes the rest from this step's
 * pressure and viscosity. The pressure is computed once per step from the step's start and
 * pushes against stiff shape springs; unfiltered, that lagged loop overshoots where the hair is
 * dense once the hold gain is large enough to give volume (Ratboy's mohawk jitters at a gain of
 * 10). Filtered, a vertex moves toward its settled place over a few frames instead of past it.
 * Measured 3 s after motion (p99.9 per frame): Ratboy with its head's distance grid 0.011 mm at
 * 0.075 s, 0.005 at 0.09, 0.003 at 0.1; the wavy rest-test groom at repulsion 0.5 0.005 mm at
 * 0.075-0.09 s, 0.0096 at 0.1 and 0.2 at 0.15 (a longer lag lets strands swing through). With
 * shape off nothing stiff holds the hair and the acceleration is not smoothed: there the lag
 * let hair lying on the colliders slide to and fro (0.31 mm per frame, 0.048 unsmoothed). */
#define SIM_SPH_SMOOTH_TIME 0.09
/* Share of a vertex's motion relative to its SPH neighbours (per evaluation, as a velocity) that
 * the hair-hair friction adds to its held acceleration each SPH evaluation (an integral hold: it
 * builds up until the motion stops, capped by hair_friction x the pressure's push). The slide it
 * stops is over-damped (internal damping, viscosity and drag near 47 /s), so the motion answers
 * the hold within a step or two. p99.9 3 s after the test motion, shape off, 96 x 16 over three
 * styles x seeds 11-13 (main 0.026-0.117 mm per frame): 0.5 overshot (0.11-0.25, in a first
 * form capped by the pair pushes); 0.05, 0.1 and 0.2 all held (<= 0.0033). 0.2 is kept: curly at 512 x 16 0.0003-0.0009 (0.1: up to 0.0087,
 * 0.05: up to 0.0044), the three styles at 512 x 16 after headbang at rest by 1.65-2.27 s (0.1:
 * curly not, 0.059), and Ratboy with its body mesh at repulsion 0.5 after shake at rest
 * (0.0090; 0.1: 0.0144, none: 0.0111). */
#define SIM_HAIR_FRICTION_GAIN 0.2
/* How often (per simulated second) the SPH pressure and viscosity are evaluated with shape on:
 * on the first step at least 1 / SIM_SPH_RATE after the last evaluation, counted in whole steps
 * (every second step at 1/60 s, every fourth at 0.008 s, every step from 1/30 s); the steps
 * between use the held, smoothed acceleration. SPH is most of a step's cost, and its
 * acceleration is low-passed over SIM_SPH_SMOOTH_TIME (a cut-off near 1.8 Hz), so sampling it
 * at 30 Hz follows it closely. At 20 Hz Ratboy at dt 0.008 s (every sixth step) no longer came
 * to rest (0.19 mm per frame). With shape off the acceleration is not smoothed and SPH runs
 * every step. */
#define SIM_SPH_RATE 30.0
/* Above this repulsion the pressure loop's gain grows with it, and so does the evaluation rate
 * (SIM_SPH_RATE x repulsion / this): Ratboy with its body mesh at repulsion 0.5 still moved
 * 0.014 mm per frame 3 s after the motion at 30 Hz, 0.001 evaluated every step. */
#define SIM_SPH_RATE_REPULSION 0.1
/* The automatic smoothing length (sph_radius = 0): this many mean root spacings (the mean
 * distance from a root to the nearest other root), clamped to [SIM_SPH_MIN_H, SIM_SPH_MAX_H]
 * metres. 1.75 spacings is 3 mm on the default 4,096-strand procedural groom. */
#define SIM_SPH_AUTO_SPACINGS 1.75
#define SIM_SPH_MIN_H 0.001
#define SIM_SPH_MAX_H 0.05
/* The smoothing length when the automatic one is not known (no memory for it): the default
 * groom's. */
#define SIM_SPH_FALLBACK_H 0.003

#endif
