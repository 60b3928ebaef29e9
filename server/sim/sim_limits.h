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
/* Contact rounds per vertex and level: push out of the colliders (vertex, then the segment's
 * midpoint), then the rest-length projection sliding along the contact's tangent plane. */
#define SIM_COLLISION_ITERATIONS 3
/* Distance a vertex is kept above a mesh's distance grid (metres), so hair sits on the surface. */
#define SIM_SDF_SKIN 0.00025
/* Most samples of a groom's distance grid the solvers accept (64 MiB of floats). */
#define SIM_SDF_MAX_SAMPLES 16777216
/* SPH accelerations use dimensionless kernels; this scale (1/s^2 per unit of repulsion and of
 * smoothing length) turns the pressure term into an acceleration (sim_cpu_sph.c). */
#define SIM_SPH_ACCEL_SCALE 3600.0

#endif
