// shaders: exclusive prefix sum of COUNT into START, one block of SCAN_BLOCK cells per
// workgroup (two cells per thread); each block's total goes to BLOCK.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x_id = 0) in; // SCAN_BLOCK / 2

shared uint tmp[SCAN_BLOCK];

void main()
{
    uint t = gl_LocalInvocationID.x;
    uint base = gl_WorkGroupID.x * SCAN_BLOCK;
    uint ncells = G.dims.w;
    uint a = base + 2u * t, b = a + 1u;
    tmp[2u * t] = a < ncells ? COUNT.d[a] : 0u;
    tmp[2u * t + 1u] = b < ncells ? COUNT.d[b] : 0u;
    // Blelloch scan: up-sweep, clear, down-sweep
    uint off = 1u;
    for (uint d = SCAN_BLOCK / 2u; d > 0u; d /= 2u) {
        barrier();
        if (t < d) {
            uint ai = off * (2u * t + 1u) - 1u, bi = off * (2u * t + 2u) - 1u;
            tmp[bi] += tmp[ai];
        }
        off *= 2u;
    }
    barrier();
    if (t == 0u) {
        BLOCK.d[gl_WorkGroupID.x] = tmp[SCAN_BLOCK - 1u];
        tmp[SCAN_BLOCK - 1u] = 0u;
    }
    for (uint d = 1u; d < SCAN_BLOCK; d *= 2u) {
        off /= 2u;
        barrier();
        if (t < d) {
            uint ai = off * (2u * t + 1u) - 1u, bi = off * (2u * t + 2u) - 1u;
            uint x = tmp[ai];
            tmp[ai] = tmp[bi];
            tmp[bi] += x;
        }
    }
    barrier();
    if (a < ncells) START.d[a] = tmp[2u * t];
    if (b < ncells) START.d[b] = tmp[2u * t + 1u];
}
