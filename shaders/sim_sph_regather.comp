// shaders: SPH steps that reuse the neighbour lists: the sorted copies are refreshed from the
// current positions and velocities in the same slot order (sim_cpu_sph.c regather_job).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x_id = 0) in;

void main()
{
    uint a = gl_GlobalInvocationID.x;
    if (a >= NS * NV) return;
    uint i = ORDER.d[a];
    SX.d[a] = vec4(ldX(i), SX.d[a].w);
    SV.d[a] = vec4(ldV(i), 0.0);
}
