// shaders: buffers and helpers of the SPH stage (port of sim_cpu_sph.c): hash grid, stable
// counting sort, capped nearest neighbours, density, pressure and viscosity.

const uint SPH_MAX_CANDIDATES = 1024u; // candidates within h gathered per particle (checked per block)
const uint SPH_SCAN_BLOCK = 64u;       // candidates examined per block
const uint SCAN_BLOCK = 512u;          // buckets per prefix-sum workgroup
const uint MAX_COORD = 1048575u;       // cell coordinates are clamped to 20 bits

layout(std430, set = 0, binding = 6) restrict buffer GridBuf {
    uint bmin[3];      // bounding box as order-preserving uint encodings of floats
    uint bmax[3];
    uint pad0[2];
    vec4 origin;       // xyz: grid origin (box minimum - one cell), w: cell size (2h)
    vec4 inv;          // x: 1 / cell size
    uvec4 dims;        // cells along x, y, z (the hash's strides); w: buckets (a power of two)
} G;
layout(std430, set = 0, binding = 7) restrict buffer CountBuf { uint d[]; } COUNT;  // per cell; zero between passes
layout(std430, set = 0, binding = 8) restrict buffer StartBuf { uint d[]; } START;  // per cell + 1: first sorted slot
layout(std430, set = 0, binding = 9) restrict buffer BlockBuf { uint d[]; } BLOCK;  // per scan block
layout(std430, set = 0, binding = 10) restrict buffer CellOfBuf { uint d[]; } CELL_OF; // per particle
layout(std430, set = 0, binding = 11) restrict buffer OrderBuf { uint d[]; } ORDER;   // sorted slot -> particle
layout(std430, set = 0, binding = 12) restrict buffer SxBuf { vec4 d[]; } SX;         // sorted positions, w: strand bits
layout(std430, set = 0, binding = 13) restrict buffer SvBuf { vec4 d[]; } SV;         // sorted velocities
layout(std430, set = 0, binding = 14) restrict buffer RhoBuf { float d[]; } RHO;      // per sorted slot
layout(std430, set = 0, binding = 15) restrict buffer PressBuf { float d[]; } PRESS;  // per sorted slot
layout(std430, set = 0, binding = 16) restrict buffer NbrBuf { uint d[]; } NBR;       // per sorted slot: cap slots
layout(std430, set = 0, binding = 17) restrict buffer NnbrBuf { uint d[]; } NNBR;     // per sorted slot
layout(std430, set = 0, binding = 22) restrict readonly buffer XeBuf { float d[]; } XE; // positions at the last evaluation
layout(std430, set = 0, binding = 23) restrict buffer AfBuf { float d[]; } AF;         // held hair-hair friction, per particle

// PC.arg0 == 1: the rest-density pass (positions from REST, zero velocities). Otherwise the
// viscosity's velocity is the motion since the last evaluation (sim_step_desc.sph_inv_since).
vec3 sph_pos(uint i) { return PC.arg0 == 1u ? ldRest(i) : ldX(i); }
vec3 ldXe(uint i) { return vec3(XE.d[3u * i], XE.d[3u * i + 1u], XE.d[3u * i + 2u]); }
vec3 sph_vel(uint i) { return PC.arg0 == 1u ? vec3(0.0) : (ldX(i) - ldXe(i)) * F.sph_inv_since; }

uint cell_coord(float p, float origin, float inv)
{
    float f = (p - origin) * inv;
    if (!(f > 0.0)) return 0u; // also NaN
    return f >= float(MAX_COORD) ? MAX_COORD : uint(f);
}

// The lower corner, along one axis, of the 2 cells (of size 2h) that hold every point within h
// of p: the cell of p and the neighbour on the side of the half p lies in.
uint lower_cell(float p, float origin, float inv)
{
    float f = (p - origin) * inv;
    uint c = cell_coord(p, origin, inv);
    return f - float(c) < 0.5 ? c - 1u : c;
}

// The cell's linear index in the box grid folded into the power-of-two bucket table (uint
// arithmetic wraps, which keeps the low bits the C backend's 64-bit index has).
uint cell_hash(uint cx, uint cy, uint cz) { return ((cz * G.dims.y + cy) * G.dims.x + cx) & (G.dims.w - 1u); }

uint bucket_of(vec3 p)
{
    return cell_hash(cell_coord(p.x, G.origin.x, G.inv.x), cell_coord(p.y, G.origin.y, G.inv.x),
                     cell_coord(p.z, G.origin.z, G.inv.x));
}
