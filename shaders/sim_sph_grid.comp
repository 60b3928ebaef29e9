// shaders: SPH grid set-up from the bounding box (one thread): cell = h, grown while the box
// would need more cells than the budget max(2n, 65536) (as sim_cpu_sph.c) or than the cell
// buffers hold (PC.arg1); writes the dispatch sizes of the per-cell passes.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x = 1) in;

void main()
{
    vec3 lo, hi;
    for (int k = 0; k < 3; k++) {
        lo[k] = key2f(G.bmin[k]);
        hi[k] = key2f(G.bmax[k]);
        bool ok = (floatBitsToUint(lo[k]) & 0x7f800000u) != 0x7f800000u &&
                  (floatBitsToUint(hi[k]) & 0x7f800000u) != 0x7f800000u && G.bmin[k] <= G.bmax[k] &&
                  G.bmin[k] != 0xffffffffu;
        if (!ok) {
            lo[k] = 0.0;
            hi[k] = 0.0;
        }
    }
    uint n = NS * NV;
    float budget = float(max(2u * n, 65536u));
    uint cap = PC.arg1;
    float cell = F.h;
    float inv = 1.0 / cell;
    uvec3 dims = uvec3(1u);
    for (int it = 0; it < 200; it++) {
        float cells = 1.0;
        for (int k = 0; k < 3; k++) cells *= floor((hi[k] - lo[k]) / cell) + 1.0;
        inv = 1.0 / cell;
        for (int k = 0; k < 3; k++) dims[k] = uint(floor((hi[k] - lo[k]) * inv)) + 1u;
        bool fits = float(dims.x) * float(dims.y) * float(dims.z) <= float(cap) && dims.x * dims.y * dims.z <= cap;
        if (cells <= budget && fits) break;
        cell *= pow(max(cells / budget, 1.0), 1.0 / 3.0) * 1.01;
    }
    uint ncells = dims.x * dims.y * dims.z;
    G.origin = vec4(lo, cell);
    G.inv = vec4(inv, 0.0, 0.0, 0.0);
    G.dims = uvec4(dims, ncells);
    G.disp_cells = uvec4((ncells + 63u) / 64u, 1u, 1u, 0u);
    uint nblocks = (ncells + SCAN_BLOCK - 1u) / SCAN_BLOCK;
    G.disp_blocks = uvec4(nblocks, 1u, 1u, nblocks);
}
