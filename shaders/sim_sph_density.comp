// shaders: per sorted slot, the particles of other strands within h in the buckets of the 2x2x2
// cells (size 2h) around it (bucket ranges sorted and merged, scanned in blocks of SPH_SCAN_BLOCK until
// SPH_MAX_CANDIDATES are gathered, as sim_cpu_sph.c), the cap nearest of them by (r^2, slot),
// the density, the pressure (not in the rest-density pass) and the neighbour list.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sim_common.glsl"
#include "sim_sph.glsl"

layout(local_size_x_id = 0) in;

// The kept candidates: in gather order while at most cap are found, then a max-heap.
float kr2[MAX_NEIGHBORS];
uint kslot[MAX_NEIGHBORS];
int kn, kcap;

bool key_less(int a, int b) { return kr2[a] < kr2[b] || (kr2[a] == kr2[b] && kslot[a] < kslot[b]); }

void key_swap(int a, int b)
{
    float r = kr2[a];
    uint s = kslot[a];
    kr2[a] = kr2[b];
    kslot[a] = kslot[b];
    kr2[b] = r;
    kslot[b] = s;
}

void sift_down(int i)
{
    for (;;) {
        int l = 2 * i + 1, r = l + 1, m = i;
        if (l < kn && key_less(m, l)) m = l;
        if (r < kn && key_less(m, r)) m = r;
        if (m == i) return;
        key_swap(i, m);
        i = m;
    }
}

// Offers candidate number m (0-based) of this particle.
void offer(uint m, float r2, uint slot)
{
    if (kn < kcap) {
        kr2[kn] = r2;
        kslot[kn] = slot;
        kn++;
        return;
    }
    if (m == uint(kcap)) // the first overflow: the list becomes a max-heap
        for (int i = kcap / 2 - 1; i >= 0; i--) sift_down(i);
    if (!(r2 < kr2[0] || (r2 == kr2[0] && slot < kslot[0]))) return;
    kr2[0] = r2;
    kslot[0] = slot;
    sift_down(0);
}

void main()
{
    uint a = gl_GlobalInvocationID.x;
    if (a >= NS * NV) return;
    vec4 pa = SX.d[a];
    vec3 xi = pa.xyz;
    uint si = floatBitsToUint(pa.w);
    // bucket ranges [lo, hi] of the 2x2x2 cells (of size 2h) on this particle's side of its
    // cell: one run of two buckets per row, split where the fold wraps, sorted by lo, merged
    uint x0 = lower_cell(xi.x, G.origin.x, G.inv.x), y0 = lower_cell(xi.y, G.origin.y, G.inv.x),
         z0 = lower_cell(xi.z, G.origin.z, G.inv.x);
    uint mask = G.dims.w - 1u;
    uint rlo[8], rhi[8];
    int n = 0;
    for (uint z = z0; z != z0 + 2u; z++)
        for (uint y = y0; y != y0 + 2u; y++) {
            uint b0 = cell_hash(x0, y, z), b1 = (b0 + 1u) & mask;
            uint seg_lo[2] = uint[2](b0, 0u), seg_hi[2] = uint[2](b1, b1);
            int segs = 1;
            if (b1 < b0) {
                seg_hi[0] = mask;
                segs = 2;
            }
            for (int k = 0; k < segs; k++) {
                int i = n++;
                while (i > 0 && rlo[i - 1] > seg_lo[k]) {
                    rlo[i] = rlo[i - 1];
                    rhi[i] = rhi[i - 1];
                    i--;
                }
                rlo[i] = seg_lo[k];
                rhi[i] = seg_hi[k];
            }
        }
    int nr = 0;
    for (int k = 0; k < n; k++) {
        if (nr > 0 && rlo[k] <= rhi[nr - 1] + 1u) {
            if (rhi[k] > rhi[nr - 1]) rhi[nr - 1] = rhi[k];
        } else {
            rlo[nr] = rlo[k];
            rhi[nr] = rhi[k];
            nr++;
        }
    }
    float h2 = F.h2;
    kn = 0;
    kcap = int(F.cap);
    uint m = 0u;
    for (int r = 0; r < nr; r++) {
        uint rb = START.d[rlo[r]], re = START.d[rhi[r] + 1u];
        for (uint j0 = rb; j0 < re && m < SPH_MAX_CANDIDATES; j0 += SPH_SCAN_BLOCK) {
            uint j1 = re - j0 < SPH_SCAN_BLOCK ? re : j0 + SPH_SCAN_BLOCK;
            for (uint j = j0; j < j1; j++) {
                vec4 pj = SX.d[j];
                float dx = pj.x - xi.x, dy = pj.y - xi.y, dz = pj.z - xi.z;
                float r2 = (dx * dx + dy * dy) + dz * dz;
                if (r2 < h2 && floatBitsToUint(pj.w) != si) {
                    offer(m, r2, j);
                    m++;
                }
            }
        }
    }
    float rho = 1.0;
    uint cap = F.cap;
    for (int k = 0; k < kn; k++) {
        float q = 1.0 - kr2[k] * F.inv_h2;
        rho += q * q * q;
        NBR.d[a * cap + uint(k)] = kslot[k];
    }
    NNBR.d[a] = uint(kn);
    RHO.d[a] = rho;
    PRESS.d[a] = max0(rho * F.inv_rho0 - 1.0);
}
