/* codec: format constants, residual tokens, context tables and predictors shared by the
 * encoder and the decoder (proto/CODEC.md is the normative description). */
#ifndef CODEC_CODEC_INTERNAL_H
#define CODEC_CODEC_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "codec.h"

/* rANS: 12-bit probabilities, byte-wise renormalisation, state in [2^23, 2^31), two states. */
#define CODEC_SCALE_BITS 12u
#define CODEC_SCALE (1u << CODEC_SCALE_BITS)
#define CODEC_RANS_L (1u << 23)

/* Residuals are coded per vertex: one rANS symbol holds the magnitude class of all three axes,
 * sym = c0 + 7 c1 + 49 c2, and raw bits give signs and the bits below the leading one.
 * Class of |r| = m: 0 for 0, c (1..5) for 2^(c-1) <= m < 2^c, 6 (escape) for m >= 32; an
 * escaped axis adds a symbol of table CODEC_T_ESC for floor(log2 m). */
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
#define CODEC_T_ESC (CODEC_T_BODY + CODEC_NBODY) /* e - 5 of an escaped axis (e = floor(log2 m)) */
#define CODEC_NESC 25u                           /* e in 5..29 */
#define CODEC_NTABLES (CODEC_T_ESC + 1u)

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

/* Smooth linear prediction at coordinate index i (vertex >= 3): the previous vertex plus the
 * mean of the two previous segments (less amplification of quantisation noise than 2a - b). */
static inline int32_t codec_smooth(const int32_t *P, uint32_t i)
{
    return P[i - 3u] + codec_half(P[i - 3u] - P[i - 9u]);
}

/* Predicted lattice coordinate of vertex v (>= 1), axis a, of the current strand.
 * P: this strand so far (this frame); K: the same strand in the motion-compensated keyframe
 * (deltas only);
 * N: the previous strand sent, this frame (NULL for the first strand).
 * All inputs are below CODEC_MAX_QUANT in magnitude, so no sum overflows. */
static inline int32_t codec_predict(bool key, uint32_t mode, const int32_t *P, const int32_t *K,
                                    const int32_t *N, uint32_t v, uint32_t a)
{
    uint32_t i = 3u * v + a, p = i - 3u, pp = i - 6u;
    if (key) {
        if (mode == 1u && N) return P[p] + N[i] - N[p];
        if (v == 1u) return N ? P[p] + N[i] - N[p] : P[p];
        if (mode == 2u && v >= 3u) return codec_smooth(P, i);
        return 2 * P[p] - P[pp];
    }
    switch (mode) {
    case 1u:
        if (v == 1u) break;
        return P[p] + K[i] - K[p] + (P[p] - K[p]) - (P[pp] - K[pp]);
    case 2u:
        if (v == 1u) break;
        return 2 * P[p] - P[pp];
    case 3u:
        if (v == 1u) break;
        if (v == 2u) return 2 * P[p] - P[pp];
        return codec_smooth(P, i);
    default:
        break;
    }
    return P[p] + K[i] - K[p];
}

/* Predicted root coordinate (axis a) of the current strand. */
static inline int32_t codec_predict_root(bool key, const int32_t *K, const int32_t *N,
                                         const int32_t *KN, uint32_t a)
{
    if (key) return N ? N[a] : 0;
    return K[a] + (N ? N[a] - KN[a] : 0);
}

/* Header layout helpers (little-endian). */
static inline void codec_put_u16(uint8_t *p, uint32_t v) { p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); }
static inline void codec_put_u32(uint8_t *p, uint32_t v)
{
    for (int k = 0; k < 4; k++) p[k] = (uint8_t)(v >> (8 * k));
}
static inline void codec_put_u64(uint8_t *p, uint64_t v)
{
    for (int k = 0; k < 8; k++) p[k] = (uint8_t)(v >> (8 * k));
}
static inline uint32_t codec_get_u16(const uint8_t *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8; }
static inline uint32_t codec_get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static inline uint64_t codec_get_u64(const uint8_t *p)
{
    return (uint64_t)codec_get_u32(p) | (uint64_t)codec_get_u32(p + 4) << 32;
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
#define CODEC_OFF_CRC 64u

/* Delta frames start their payload with a rigid motion in lattice units: 12 f32, the rotation
 * row-major then the translation; the decoder predicts from the keyframe moved by it. */
#define CODEC_MOTION_BYTES 48u

void codec_motion_identity(float m[12]);

/* True when every rotation entry is within [-2, 2] and the translation within 2^28. */
bool codec_motion_valid(const float m[12]);

/* Least-squares rigid motion taking the keyframe's roots to this frame's (lattice units, root j
 * at key[3 j .. 3 j + 2], cur[3 j .. 3 j + 2]); identity when it cannot be estimated. */
void codec_motion_estimate(const int32_t *key, const int32_t *cur, uint32_t nstrands, float m[12]);

/* out = round(R k + t) per vertex (binary64, exactly as proto/CODEC.md; clamped to the lattice
 * range). m must be codec_motion_valid. */
void codec_motion_apply(const float m[12], const int32_t *k, int32_t *out, size_t nverts);

/* Quantization step for a bound: 2 * bound * (1 - 2^-5), leaving room for float32 rounding. */
double codec_step_for_bound(float max_error_m);

/* Writes the fixed header into p[0..CODEC_HEADER_SIZE) (CRC field zero). */
void codec_header_write(uint8_t *p, const codec_frame_info *info);

/* Grows buf to hold at least cap bytes. */
core_status codec_buf_reserve(codec_buf *buf, size_t cap, core_err *err);

/* zlib's crc32(crc, p, n) (CRC-32, reflected polynomial 0xEDB88320; crc 0 to start). */
uint32_t codec_crc32(uint32_t crc, const uint8_t *p, size_t n);

/* CRC-32 (zlib) of a frame: header bytes 0..63, then the payload. */
uint32_t codec_frame_crc(const uint8_t *frame, size_t payload_len);

#endif
