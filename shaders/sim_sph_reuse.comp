// shaders: SPH steps that reuse the neighbour lists: the density over the kept neighbours at
// their current distances, and the pressure (sim_cpu_sph.c density_reuse_job, pressure_job).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x_id = 0) in;

void main()
{
    uint a = gl_GlobalInvocationID.x;
    if (a >= NS * NV) return;
    vec3 pi = SX.d[a].xyz;
    uint cap = F.cap, nn = NNBR.d[a];
    float rho = 1.0;
    for (uint k = 0u; k < nn; k++) {
        vec3 pj = SX.d[NBR.d[a * cap + k]].xyz;
        float dx = pj.x - pi.x, dy = pj.y - pi.y, dz = pj.z - pi.z;
        float q = max0(1.0 - ((dx * dx + dy * dy) + dz * dz) * F.inv_h2);
        rho += q * q * q;
    }
    RHO.d[a] = rho;
    PRESS.d[a] = max0(rho * F.inv_rho0 - 1.0);
}
