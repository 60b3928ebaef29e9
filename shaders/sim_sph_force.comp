// shaders: per sorted slot, the pressure and viscosity accelerations over its neighbour list
// (as sim_cpu_sph.c force_job), smoothed with the previous step's in A at the particle's unsorted
// index (less the held hair-hair friction it included) and written there with the new held
// friction (sim_cpu_sph.c hold_accel), which AF keeps.
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
    vec3 acc = vec3(0.0), hold = vec3(0.0);
    uint o = ORDER.d[i];
    vec3 af = vec3(AF.d[3u * o], AF.d[3u * o + 1u], AF.d[3u * o + 2u]);
    if (W > 0.0) {
        // hair-hair static friction: the held acceleration grows against the motion relative to
        // the neighbours' weighted mean, capped at hair_friction x the pressure's push
        float g = float(SIM_HAIR_FRICTION_GAIN) * F.inv_step_dt;
        vec3 vbar = vb / W;
        hold = vec3(af.x - g * (vi.x - vbar.x), af.y - g * (vi.y - vbar.y), af.z - g * (vi.z - vbar.z));
        float lim = F.hair_friction * F.kp / RHO.d[i] * Pi * W;
        float l = sqrt((hold.x * hold.x + hold.y * hold.y) + hold.z * hold.z);
        bool held = l <= lim, slips = l > lim; // both false when either is NaN (dropped)
        hold = held || slips ? hold * (slips ? lim / l : 1.0) : vec3(0.0);
        float kr = F.kp / RHO.d[i];
        acc = ap * kr;
        // viscosity: mu (W / rho_i) (vbar - v_i), integrated exactly over the step (sim_cpu_sph.c)
        float blend = (1.0 - exp(-F.mu_dt * W / RHO.d[i])) * F.inv_step_dt;
        acc += blend * (vb / W - vi);
    }
    // the low-pass (sim_limits.h SIM_SPH_SMOOTH_TIME), per component as sim_cpu_sph.c smooth_accel
    vec3 prev = ldA(o) - af;
    stA(o, vec3(acc.x + F.sph_keep * (prev.x - acc.x), acc.y + F.sph_keep * (prev.y - acc.y),
                acc.z + F.sph_keep * (prev.z - acc.z)) + hold);
    AF.d[3u * o] = hold.x;
    AF.d[3u * o + 1u] = hold.y;
    AF.d[3u * o + 2u] = hold.z;
}
