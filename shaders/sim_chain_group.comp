// shaders: the chain pass with one workgroup per group of GS strands: the workgroup predicts
// all the group's particles in parallel into shared memory, then one thread per strand walks
// its chain there. One dispatch per substep.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 3) const uint GS = 1u; // strands per workgroup (<= the workgroup size)

shared float pred[3u * GS * NV];

void main()
{
    uint t = gl_LocalInvocationID.x;
    uint nt = gl_WorkGroupSize.x;
    uint s0 = gl_WorkGroupID.x * GS;
    uint k = PC.substep;
    // phase 1: predictions of levels >= 1 into slot (l, j) for strand s0 + j
    for (uint slot = GS + t; slot < GS * NV; slot += nt) {
        uint l = slot / GS, j = slot % GS;
        if (s0 + j >= NS) continue;
        vec3 x = chain_predict(l * NS + s0 + j);
        pred[3u * slot] = x.x;
        pred[3u * slot + 1u] = x.y;
        pred[3u * slot + 2u] = x.z;
    }
    barrier();
    // phase 2: the serial chain, one thread per strand
    uint s = s0 + t;
    if (t >= GS || s >= NS) return;
    Chain ch = chain_root(s, k);
    for (uint l = 1u; l < NV; l++) {
        uint slot = l * GS + t;
        chain_solve(s, l, k, vec3(pred[3u * slot], pred[3u * slot + 1u], pred[3u * slot + 2u]), ch);
    }
    chain_finish(s, k, ch);
}
