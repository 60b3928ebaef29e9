// shaders: per sorted slot, the cap nearest particles of other strands within h (a max-heap on
// (r^2, slot) over the 9 rows of 3 cells around it, as sim_cpu_sph.c), the density over them
// in heap order, the pressure (not in the rest-density pass), and the neighbour list.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x_id = 0) in;

float hr2[MAX_NEIGHBORS];
uint hslot[MAX_NEIGHBORS];
int hn, hcap;

bool heap_less(int a, int b) { return hr2[a] < hr2[b] || (hr2[a] == hr2[b] && hslot[a] < hslot[b]); }

void heap_swap(int a, int b)
{
    float r = hr2[a];
    uint s = hslot[a];
    hr2[a] = hr2[b];
    hslot[a] = hslot[b];
    hr2[b] = r;
    hslot[b] = s;
}

void heap_offer(float r2, uint slot)
{
    if (hn < hcap) {
        int i = hn++;
        hr2[i] = r2;
        hslot[i] = slot;
        while (i > 0 && heap_less((i - 1) / 2, i)) {
            heap_swap(i, (i - 1) / 2);
            i = (i - 1) / 2;
        }
        return;
    }
    if (!(r2 < hr2[0] || (r2 == hr2[0] && slot < hslot[0]))) return;
    hr2[0] = r2;
    hslot[0] = slot;
    int i = 0;
    for (;;) {
        int l = 2 * i + 1, r = l + 1, m = i;
        if (l < hn && heap_less(m, l)) m = l;
        if (r < hn && heap_less(m, r)) m = r;
        if (m == i) break;
        heap_swap(i, m);
        i = m;
    }
}

void main()
{
    uint a = gl_GlobalInvocationID.x;
    uint n = NS * NV;
    if (a >= n) return;
    uint cell = CELL_OF.d[ORDER.d[a]];
    uint dx = G.dims.x, dy = G.dims.y, dz = G.dims.z, ncells = G.dims.w;
    uint cx = cell % dx, cy = cell / dx % dy, cz = cell / dx / dy;
    uint x0 = cx > 0u ? cx - 1u : 0u, x1 = cx + 1u < dx ? cx + 1u : dx - 1u;
    vec3 xi = SX.d[a].xyz;
    uint si = ORDER.d[a] % NS;
    float h2 = F.h2;
    hn = 0;
    hcap = int(F.cap);
    uint examined = 0u;
    for (int oz = -1; oz <= 1; oz++) {
        if ((oz < 0 && cz == 0u) || (oz > 0 && cz + 1u >= dz)) continue;
        for (int oy = -1; oy <= 1; oy++) {
            if ((oy < 0 && cy == 0u) || (oy > 0 && cy + 1u >= dy)) continue;
            if (examined >= SPH_MAX_CANDIDATES) continue;
            uint row = (uint(int(cz) + oz) * dy + uint(int(cy) + oy)) * dx;
            uint rb = START.d[row + x0], re = START.d[row + x1 + 1u];
            examined += re - rb;
            for (uint j = rb; j < re; j++) {
                vec3 d = SX.d[j].xyz - xi;
                float r2 = d.x * d.x + d.y * d.y + d.z * d.z;
                if (r2 < h2 && ORDER.d[j] % NS != si) heap_offer(r2, j);
            }
        }
    }
    float rho = 1.0;
    uint cap = F.cap;
    for (int k = 0; k < hn; k++) {
        float q = 1.0 - hr2[k] * F.inv_h2;
        rho += q * q * q;
        NBR.d[a * cap + uint(k)] = hslot[k];
    }
    NNBR.d[a] = uint(hn);
    RHO.d[a] = rho;
    PRESS.d[a] = max(rho * F.inv_rho0 - 1.0, 0.0);
}
