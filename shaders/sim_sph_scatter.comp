// shaders: places every particle in its cell's range of sorted slots (in any order inside the
// cell; sim_sph_cellsort makes it stable) and counts COUNT back down to zero.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x_id = 0) in;

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= NS * NV) return;
    uint cell = CELL_OF.d[i];
    uint left = atomicAdd(COUNT.d[cell], 0xffffffffu);
    ORDER.d[START.d[cell] + left - 1u] = i;
}
