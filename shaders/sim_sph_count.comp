// shaders: SPH cell of every particle and the per-cell counts (COUNT is zero on entry).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x_id = 0) in;

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= NS * NV) return;
    uint cell = bucket_of(sph_pos(i));
    CELL_OF.d[i] = cell;
    atomicAdd(COUNT.d[cell], 1u);
}
