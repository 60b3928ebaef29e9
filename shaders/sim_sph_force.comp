// shaders: per sorted slot, the pressure and viscosity accelerations over its neighbour list
// (as sim_cpu_sph.c force_job), smoothed with the previous step's in A at the particle's unsorted
// index and written there.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x_id = 0) in;

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= NS * NV) return;
    vec3 pi = SX.d[i].xyz, vi = SV.d[i].xyz;
    float Pi = PRESS.d[i];
    vec3 ap = vec3(0.0), vb = vec3(0.0);
    float W = 0.0;
    uint cap = F.cap, nn = NNBR.d[i];
    for (uint k = 0u; k < nn; k++) {
        uint j = NBR.d[i * cap + k];
        vec3 pj = SX.d[j].xyz, vj = SV.d[j].xyz;
        vec3 d = pi - pj;
        float r = sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
        float q = max0(1.0 - r * F.inv_h); // a kept neighbour may have moved beyond h
        float inv_rhoj = 1.0 / RHO.d[j];
        if (r > 1e-9) {
            float f = (Pi + PRESS.d[j]) * 0.5 * inv_rhoj * q * q / r;
            ap += f * d;
        }
        float w = q * inv_rhoj;
        W += w;
        vb += w * vj;
    }
    vec3 acc = vec3(0.0);
    if (W > 0.0) {
        float kr = F.kp / RHO.d[i];
        acc = ap * kr;
        // viscosity: mu (W / rho_i) (vbar - v_i), integrated exactly over the step (sim_cpu_sph.c)
        float blend = (1.0 - exp(-F.mu_dt * W / RHO.d[i])) * F.inv_step_dt;
        acc += blend * (vb / W - vi);
    }
    // the low-pass (sim_limits.h SIM_SPH_SMOOTH_TIME), per component as sim_cpu_sph.c smooth_accel
    uint o = ORDER.d[i];
    vec3 prev = ldA(o);
    stA(o, vec3(acc.x + F.sph_keep * (prev.x - acc.x), acc.y + F.sph_keep * (prev.y - acc.y),
                acc.z + F.sph_keep * (prev.z - acc.z)));
}
