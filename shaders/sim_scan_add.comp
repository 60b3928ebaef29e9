// shaders: adds each scan block's offset to its cells' START entries.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x_id = 0) in; // SCAN_BLOCK / 2

void main()
{
    uint t = gl_LocalInvocationID.x;
    uint base = gl_WorkGroupID.x * SCAN_BLOCK;
    uint ncells = G.dims.w, add = BLOCK.d[gl_WorkGroupID.x];
    uint a = base + 2u * t, b = a + 1u;
    if (a < ncells) START.d[a] += add;
    if (b < ncells) START.d[b] += add;
}
