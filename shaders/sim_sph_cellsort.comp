// shaders: sorts each bucket's slots by particle index (a stable counting sort overall, as the
// C backend's) and gathers the sorted positions (with the strand in w) and velocities.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x_id = 0) in;

void main()
{
    uint cell = gl_GlobalInvocationID.x;
    if (cell >= G.dims.w) return;
    uint first = START.d[cell], last = START.d[cell + 1u];
    for (uint a = first + 1u; a < last; a++) {
        uint v = ORDER.d[a];
        uint b = a;
        while (b > first && ORDER.d[b - 1u] > v) {
            ORDER.d[b] = ORDER.d[b - 1u];
            b--;
        }
        ORDER.d[b] = v;
    }
    for (uint a = first; a < last; a++) {
        uint i = ORDER.d[a];
        SX.d[a] = vec4(sph_pos(i), uintBitsToFloat(i % NS));
        SV.d[a] = vec4(sph_vel(i), 0.0);
    }
}
