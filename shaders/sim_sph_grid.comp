// shaders: SPH grid set-up from the bounding box (one thread), as sim_cpu_sph.c: cells of size
// 2h from one cell below the box minimum, (box / 2h) + 2 cells per axis (at most 2^20), hashed
// into PC.arg1 buckets.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x = 1) in;

// floor(a * b) of the exact product, as the C backend's double arithmetic gives it.
float floor_exact(float a, float b)
{
    float p = a * b;
    float f = floor(p);
    return f == p && fma(a, b, -p) < 0.0 ? f - 1.0 : f;
}

void main()
{
    float cell = 2.0 * F.h, inv = 1.0 / cell;
    vec3 origin;
    uvec3 dims;
    for (int k = 0; k < 3; k++) {
        float lo = keyf(G.bmin[k]), hi = keyf(G.bmax[k]);
        bool ok = G.bmin[k] != 0xffffffffu && (floatBitsToUint(lo) & 0x7f800000u) != 0x7f800000u &&
                  (floatBitsToUint(hi) & 0x7f800000u) != 0x7f800000u;
        if (!ok) {
            lo = 0.0;
            hi = 0.0;
        }
        origin[k] = lo - cell;
        float cells = floor_exact(hi - origin[k], inv) + 2.0;
        dims[k] = cells < 1048576.0 ? uint(cells) : 1048576u;
    }
    G.origin = vec4(origin, cell);
    G.inv = vec4(inv, 0.0, 0.0, 0.0);
    G.dims = uvec4(dims, PC.arg1);
}
