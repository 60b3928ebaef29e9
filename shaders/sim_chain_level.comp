// shaders: the chain pass with particle-level parallelism: one dispatch per level l >= 1, one
// thread per strand; the chain state (position, frame, NaN flag, velocity, the level before's
// positions, the length projection's damping share) is carried in STRAND, 5 vec4 per strand.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_collide.glsl"
#include "sim_chain.glsl"

layout(local_size_x_id = 0) in; // CHUNK

void main()
{
    uint s = gl_GlobalInvocationID.x;
    bool live = s < NS;
    uint k = PC.substep, l = PC.level;
    Chain ch;
    if (l == 1u) {
        ch = chain_root(live, s, k);
    } else if (live) {
        uint j = (l - 1u) * NS + s; // level l - 1 is written by this pass: its x is still old
        vec4 pb = STRAND.d[5u * s];
        ch.p = pb.xyz;
        ch.bad = pb.w != 0.0;
        ch.q = STRAND.d[5u * s + 1u];
        ch.pv = STRAND.d[5u * s + 2u].xyz;
        ch.gp = STRAND.d[5u * s + 3u].xyz;
        ch.f = STRAND.d[5u * s + 3u].w;
        ch.go = STRAND.d[5u * s + 4u].xyz;
        ch.o = ldX(j);
        ch.pr = ldRest(j);
    } else {
        ch = chain_root(false, s, k);
    }
    if (contacts_on()) { // the chunk's box buffer starts empty
        if (gl_LocalInvocationID.x == 0u) box_reset(0u);
        barrier();
    }
    chain_solve(live, s, l, k, 0u, 0u, live ? chain_predict(l * NS + s) : vec3(0.0), ch);
    if (!live) return;
    if (l == NV - 1u) {
        chain_finish(s, k, ch);
    } else {
        STRAND.d[5u * s] = vec4(ch.p, ch.bad ? 1.0 : 0.0);
        STRAND.d[5u * s + 1u] = ch.q;
        STRAND.d[5u * s + 2u] = vec4(ch.pv, 0.0);
        STRAND.d[5u * s + 3u] = vec4(ch.gp, ch.f);
        STRAND.d[5u * s + 4u] = vec4(ch.go, 0.0);
    }
}
