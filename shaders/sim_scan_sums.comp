// shaders: exclusive prefix sum of the scan blocks' totals in place (one workgroup, in chunks
// of its size) and the end marker START[ncells] = number of particles.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x_id = 0) in;

shared uint tmp[1024];

void main()
{
    uint t = gl_LocalInvocationID.x, nt = gl_WorkGroupSize.x;
    uint nblocks = G.dims.w / SCAN_BLOCK;
    uint carry = 0u;
    for (uint base = 0u; base < nblocks; base += nt) {
        uint v = base + t < nblocks ? BLOCK.d[base + t] : 0u;
        tmp[t] = v;
        // Hillis-Steele inclusive scan
        for (uint d = 1u; d < nt; d *= 2u) {
            barrier();
            uint add = t >= d ? tmp[t - d] : 0u;
            barrier();
            tmp[t] += add;
        }
        barrier();
        if (base + t < nblocks) BLOCK.d[base + t] = carry + tmp[t] - v;
        carry += tmp[nt - 1u];
        barrier();
    }
    if (t == 0u) START.d[G.dims.w] = NS * NV;
}
