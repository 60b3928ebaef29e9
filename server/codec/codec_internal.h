/* codec: format constants, residual tokens, context tables and predictors of the encoder and the
 * decoder's host side (proto/CODEC.md is the normative description; the decode core,
 * codec_core.c, is freestanding and states the constants it needs itself). */
#ifndef CODEC_CODEC_INTERNAL_H
#define CODEC_CODEC_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "codec.h"

/* rANS: 12-bit probabilities, 16-bit renormalisation, states in [2^16, 2^32), one state per lane
 * of a group of CODEC_LANES strands. */
#define CODEC_MIN_ERROR 1e-5f /* the per-axis error bound a frame may carry, m */
#define CODEC_MAX_ERROR 0.1f
#define CODEC_SCALE_BITS 12u
#define CODEC_SCALE (1u << CODEC_SCALE_BITS)
#define CODEC_RANS_L (1u << 16)
#define CODEC_LANES 8u
#define CODEC_RANS_HEAD (4u * CODEC_LANES) /* the initial states at the start of the stream */

/* Residuals are coded per vertex: one rANS symbol holds the magnitude class of all three axes,
 * sym = c0 + 7 c1 + 49 c2, and raw bits give signs and the bits below the leading one.
 * Class of |r| = m: 0 for 0, c (1..5) for 2^(c-1) <= m < 2^c, 6 (escape) for m >= 32; an
 * escaped axis has floor(log2 m) - 5 in CODEC_ESC_BITS raw bits (at most CODEC_ESC_MAX). */
#define CODEC_NCLASS 7u
#define CODEC_ESCAPE 6u
#define CODEC_NSYM (CODEC_NCLASS * CODEC_NCLASS * CODEC_NCLASS)

/* Prediction modes, chosen per strand. */
#define CODEC_KEY_MODES 3u       /* keyframes: linear, neighbour segment, smooth linear */
#define CODEC_DELTA_MODES 4u     /* deltas: key segment, displacement, linear, smooth linear */

/* Context tables: strand mode, roots, first segment, body by the previous vertex's top class. */
#define CODEC_NBODY 6u
#define CODEC_T_MODE 0u
#define CODEC_T_ROOT 1u
#define CODEC_T_FIRST 2u
#define CODEC_T_BODY 3u
#define CODEC_NTABLES (CODEC_T_BODY + CODEC_NBODY)
#define CODEC_ESC_BITS 5u
#define CODEC_ESC_MAX 24u /* e - 5 for e in 5..29 */

static inline uint32_t codec_class(uint32_t m)
{
    if (m == 0) return 0;
    uint32_t c = 32u - (uint32_t)__builtin_clz(m);
    return c < CODEC_ESCAPE ? c : CODEC_ESCAPE;
}

/* Body table for the vertex after one whose classes were c0, c1, c2. */
static inline uint32_t codec_body_table(uint32_t c0, uint32_t c1, uint32_t c2)
{
    uint32_t m = c0 > c1 ? c0 : c1;
    m = m > c2 ? m : c2;
    return CODEC_T_BODY + (m < CODEC_NBODY - 1u ? m : CODEC_NBODY - 1u);
}

/* d / 2 rounded half to even (arithmetic shifts; exact for any int32 d). */
static inline int32_t codec_half(int32_t d)
{
    return (d + ((d >> 1) & 1)) >> 1;
}

/* Header writers (little-endian; the decode core, codec_core.c, has its own readers). */
static inline void codec_put_u16(uint8_t *p, uint32_t v) { p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); }
static inline void codec_put_u32(uint8_t *p, uint32_t v)
{
    for (int k = 0; k < 4; k++) p[k] = (uint8_t)(v >> (8 * k));
}
static inline void codec_put_u64(uint8_t *p, uint64_t v)
{
    for (int k = 0; k < 8; k++) p[k] = (uint8_t)(v >> (8 * k));
}

/* Header field offsets. */
#define CODEC_OFF_VERSION 4u
#define CODEC_OFF_CODEC 6u
#define CODEC_OFF_FLAGS 7u
#define CODEC_OFF_SEQ 8u
#define CODEC_OFF_REF 16u
#define CODEC_OFF_TIME 24u
#define CODEC_OFF_STEP 32u
#define CODEC_OFF_BOUND 40u
#define CODEC_OFF_TOTAL 44u
#define CODEC_OFF_SENT 48u
#define CODEC_OFF_NVERTS 52u
#define CODEC_OFF_STRIDE 56u
#define CODEC_OFF_PAYLOAD 60u
#define CODEC_OFF_SIM_STEP 64u
#define CODEC_OFF_HEAD_POS 72u
#define CODEC_OFF_HEAD_ROT 84u
#define CODEC_OFF_CRC 100u

/* Delta frames start their payload with a rigid motion in lattice units: nine i16 rotation
 * entries (2^-14 units, row-major), two zero bytes, three i32 translations, 16 zero bytes. */
#define CODEC_MOTION_BYTES 48u
#define CODEC_RHO_ONE 16384          /* 1.0 in rotation units; also the largest |rho| */
#define CODEC_T_MAX (1 << 28)        /* the largest |t| */
#define CODEC_SEG_MAX 32767          /* keyframe segments are clamped to this before rotation */

typedef struct codec_motion {
    int32_t rho[9]; /* rotation, row-major, units of 2^-14, each in [-16384, 16384] */
    int32_t t[3];   /* translation, lattice units, each in [-2^28, 2^28] */
} codec_motion;

void codec_motion_identity(codec_motion *m);

/* The 48 bytes of m at p (m must be in range). */
void codec_motion_write(uint8_t *p, const codec_motion *m);

/* Least-squares rigid motion taking the keyframe's roots to this frame's (lattice units, root j
 * at key[3 j .. 3 j + 2], cur[3 j .. 3 j + 2]; the roots j = 0, step, 2 step, ... below
 * nstrands), quantised; identity when it cannot be estimated. */
void codec_motion_estimate(const int32_t *key, const int32_t *cur, uint32_t nstrands, uint32_t step, codec_motion *m);

/* Axis a of the moved root of a strand whose keyframe root is k (exact; proto/CODEC.md). */
static inline int32_t codec_moved_root(const codec_motion *m, const int32_t k[3], uint32_t a)
{
    const int32_t *r = m->rho + 3u * a;
    int64_t s = (int64_t)r[0] * k[0] + (int64_t)r[1] * k[1] + (int64_t)r[2] * k[2] + 8192;
    int64_t w = (s >> 14) + m->t[a];
    const int64_t lim = CODEC_MAX_QUANT - 1;
    return (int32_t)(w < -lim ? -lim : w > lim ? lim : w);
}

static inline int32_t codec_clamp15(int32_t d)
{
    return d < -CODEC_SEG_MAX ? -CODEC_SEG_MAX : d > CODEC_SEG_MAX ? CODEC_SEG_MAX : d;
}

/* Axis a of the moved segment of the (clamped) keyframe segment d (proto/CODEC.md). */
static inline int32_t codec_moved_seg(const codec_motion *m, const int32_t d[3], uint32_t a)
{
    const int32_t *r = m->rho + 3u * a;
    return (r[0] * d[0] + r[1] * d[1] + r[2] * d[2] + 8192) >> 14;
}

/* Quantization step for a bound: 2 * bound * (1 - 2^-5), leaving room for float32 rounding. */
double codec_step_for_bound(float max_error_m);

/* Writes the fixed header into p[0..CODEC_HEADER_SIZE) (CRC field zero). */
void codec_header_write(uint8_t *p, const codec_frame_info *info);

/* Grows buf to hold at least cap bytes. */
core_status codec_buf_reserve(codec_buf *buf, size_t cap, core_err *err);

/* CRC-32 (zlib) of a frame: header bytes 0..99, then the payload. */
uint32_t codec_frame_crc(const uint8_t *frame, size_t payload_len);

#endif
