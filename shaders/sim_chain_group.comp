// shaders: the chain pass with one workgroup per chunk of CHUNK strands: the workgroup
// predicts all the chunk's particles in parallel into shared memory, then each thread walks
// its strand's chain from there. One dispatch per substep.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_chain.glsl"

layout(local_size_x_id = 0) in; // CHUNK

shared float pred[3u * CHUNK * NV];

void main()
{
    uint t = gl_LocalInvocationID.x;
    uint s0 = gl_WorkGroupID.x * CHUNK;
    uint k = PC.substep;
    // phase 1: predictions of levels >= 1, slot (l, j) for strand s0 + j
    for (uint slot = CHUNK + t; slot < CHUNK * NV; slot += CHUNK) {
        uint l = slot / CHUNK, j = slot % CHUNK;
        if (s0 + j >= NS) continue;
        vec3 x = chain_predict(l * NS + s0 + j);
        pred[3u * slot] = x.x;
        pred[3u * slot + 1u] = x.y;
        pred[3u * slot + 2u] = x.z;
    }
    if (gl_LocalInvocationID.x == 0u) {
        box_reset(1u); /* the box buffers of levels 1 and 2; level l resets that of l + 2 */
        box_reset(2u);
    }
    barrier();
    // phase 2: the serial chain, one thread per strand, the chunk in step for collider culling
    uint s = s0 + t;
    bool live = s < NS;
    Chain ch = chain_root(live, s, k);
    for (uint l = 1u; l < NV; l++) {
        uint slot = l * CHUNK + t;
        chain_solve(live, s, l, k, l % 3u, (l + 2u) % 3u, vec3(pred[3u * slot], pred[3u * slot + 1u], pred[3u * slot + 2u]), ch);
    }
    if (live) chain_finish(s, k, ch);
}
