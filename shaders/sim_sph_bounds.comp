// shaders: SPH bounding box of all particles (NaN ignored as fminf/fmaxf do): a workgroup
// reduction, then one atomic per axis into G.bmin/G.bmax (reset to +/-max by the host).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x_id = 0) in;

shared uint smin[3 * 256];
shared uint smax[3 * 256];

void main()
{
    uint t = gl_LocalInvocationID.x, nt = gl_WorkGroupSize.x;
    uint i = gl_GlobalInvocationID.x;
    uint lo[3] = uint[3](0xffffffffu, 0xffffffffu, 0xffffffffu), hi[3] = uint[3](0u, 0u, 0u);
    if (i < NS * NV) {
        vec3 p = sph_pos(i);
        for (int k = 0; k < 3; k++) {
            if ((floatBitsToUint(p[k]) & 0x7fffffffu) > 0x7f800000u) continue; // NaN
            lo[k] = fkey(p[k]);
            hi[k] = lo[k];
        }
    }
    for (int k = 0; k < 3; k++) {
        smin[3u * t + uint(k)] = lo[k];
        smax[3u * t + uint(k)] = hi[k];
    }
    barrier();
    for (uint w = nt / 2u; w > 0u; w /= 2u) {
        if (t < w)
            for (uint k = 0u; k < 3u; k++) {
                smin[3u * t + k] = min(smin[3u * t + k], smin[3u * (t + w) + k]);
                smax[3u * t + k] = max(smax[3u * t + k], smax[3u * (t + w) + k]);
            }
        barrier();
    }
    if (t == 0u)
        for (uint k = 0u; k < 3u; k++) {
            atomicMin(G.bmin[k], smin[k]);
            atomicMax(G.bmax[k], smax[k]);
        }
}
