/* codec: strand frame encoder/decoder with a guaranteed maximum per-axis position error. */
#ifndef CODEC_CODEC_H
#define CODEC_CODEC_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "../core/core.h"

/* The wire format is specified byte by byte in proto/CODEC.md. */
#define CODEC_MAGIC "SCF1"
#define CODEC_VERSION 3u
#define CODEC_ID_STRAND 1u         /* strand positions: strands of nverts vertices */
#define CODEC_ID_HAIRMESH 2u       /* hair mesh vertices: its columns as "strands" of nlayers
                                      vertices, all of them (stride 1) */
#define CODEC_HEADER_SIZE 104u
#define CODEC_FLAG_KEY 1u          /* keyframe: intra-coded, no reference */
#define CODEC_DEFAULT_MAX_ERROR 1e-4f
#define CODEC_DEFAULT_KEY_INTERVAL 30u
#define CODEC_MAX_VERTICES (1u << 24) /* per frame (strands sent x vertices per strand) */
#define CODEC_MAX_NVERTS 4096u
#define CODEC_MAX_QUANT (1 << 26)  /* |position / step| must stay below this */
#define CODEC_HEAD_NORM_TOL 1e-4   /* a frame's head quaternion: |x^2 + y^2 + z^2 + w^2 - 1| <= this */

/* Per-stream constants; zero means default. */
typedef struct codec_desc {
    float max_error_m;     /* per-axis bound |decoded - input| <= this; 0 -> 1e-4 m; [1e-5, 1e-1] */
    uint32_t key_interval; /* a keyframe at least every this many frames; 0 -> 30 */
    uint32_t stride;       /* send strands 0, k, 2k, ...; 0 -> 1 (all strands) */
    uint32_t codec_id;     /* the frames' codec id: 0 -> CODEC_ID_STRAND; CODEC_ID_HAIRMESH (stride 1) */
} codec_desc;

/* A caller-owned growable byte buffer. Zero-initialise it; codec_buf_free releases it. */
typedef struct codec_buf {
    uint8_t *data;
    size_t len, cap;
} codec_buf;

/* The simulation snapshot a frame's positions belong to (the header carries it). */
typedef struct codec_sim_info {
    double sim_time;         /* simulation time, s; finite */
    uint64_t sim_step;       /* the simulation's step counter */
    float head_pos[3];       /* the head transform that step used: position, m; finite */
    float head_rot[4];       /* and rotation, a unit quaternion x, y, z, w (CODEC_HEAD_NORM_TOL) */
} codec_sim_info;

/* The decoded header of one frame. */
typedef struct codec_frame_info {
    uint64_t seq;            /* this frame's sequence number */
    uint64_t ref_seq;        /* sequence of the keyframe it predicts from (== seq on keyframes) */
    codec_sim_info sim;      /* simulation time, step and head transform of the positions */
    double step;             /* quantization step, m */
    float max_error_m;       /* the per-axis error bound the encoder guaranteed */
    bool keyframe;
    uint32_t codec_id;       /* CODEC_ID_STRAND or CODEC_ID_HAIRMESH (strands are then the mesh's
                                columns, nverts its layers) */
    uint32_t nstrands_total; /* strands in the simulation */
    uint32_t nstrands_sent;  /* strands in this frame: ceil(total / stride) */
    uint32_t nverts;         /* vertices per strand (vertex 0 = root) */
    uint32_t stride;         /* strands sent are 0, stride, 2*stride, ... */
    uint32_t payload_len;    /* bytes after the header */
    size_t frame_len;        /* header + payload */
} codec_frame_info;

/* Encoder state: holds the integer reconstruction of the current keyframe. */
typedef struct codec_encoder {
    codec_desc desc;
    uint32_t nstrands_total, nstrands_sent, nverts;
    uint32_t ngroups;    /* groups of 8 sent strands (the last one may be partial) */
    double step, inv_step;
    uint64_t key_seq;
    uint32_t since_key;  /* frames since the last keyframe; key_valid false until the first */
    bool key_valid;
    bool portable;       /* use the portable kernels even where SIMD ones were built: the same
                            bytes (tests set it after init to compare the two) */
    int32_t *key_q;      /* the keyframe as deltas use it: per group of 8 strands its roots and
                            clamped segments (codec_kref_group) */
    int32_t *cur_q;      /* this frame's, when it is a keyframe */
    int32_t *key_roots, *cur_roots; /* root xyz of every sent strand: keyframe, this frame */
    uint64_t last_seq;   /* sequence numbers must increase */
    uint16_t *syms;      /* entropy-coder symbols of this frame, table * 343 + symbol */
    uint32_t *counts;    /* their histogram (several copies, summed per frame) */
    struct codec_rans_sym *rsyms; /* per-frame encoding tables */
    struct codec_rans_vsym *rvsyms; /* the same tables for the vector path */
    uint8_t *bits;       /* raw bit stream of this frame */
    uint8_t *rans;       /* rANS output, written backwards from the end */
    int32_t *work;       /* per-group scratch */
    uint32_t careful;    /* sent strands the last frame quantised one coordinate at a time */
    size_t nsyms_max, bits_cap, rans_cap;
} codec_encoder;

/* Decoder state: the decode core's (codec_core.h) and the memory it works in. */
typedef struct codec_decoder {
    struct codec_core *core; /* the core's state: the held keyframe's header, the frame's tables */
    int32_t *q[2];           /* lattice slots: the held keyframe's and the next keyframe's */
    int16_t *d[2];           /* their clamped segments */
    float *out;              /* a frame's positions, copied to the caller's once it decoded */
    uint8_t *frame;          /* a copy of the frame with CODEC_CORE_SLACK bytes after it */
    size_t q_cap, d_cap;     /* elements each q slot (and out) and each d slot hold */
    size_t frame_cap;        /* bytes frame holds */
} codec_decoder;

/* Releases buf's memory and zeroes it. Safe on a zeroed buf. */
void codec_buf_free(codec_buf *buf);

/* Sets up an encoder for nstrands x nverts strands (nverts >= 2). desc may be NULL (defaults).
 * On failure *enc is zeroed and err says why. One thread at a time uses an encoder. */
core_status codec_encoder_init(codec_encoder *enc, const codec_desc *desc, uint32_t nstrands,
                               uint32_t nverts, core_err *err);

/* Encodes one frame: xyz is 3 * nstrands * nverts floats, strand-major (caller-owned, read only);
 * sim the snapshot they belong to (time, step, head transform; caller-owned, read only), which
 * the header carries. Writes the frame to out (replacing its contents; out grows as needed). A
 * keyframe is made on the first call, every key_interval frames, and when force_key is set;
 * other frames are deltas against the last keyframe, so a decoder holding that keyframe decodes
 * any later frame in any subset. Every decoded coordinate is within max_error_m of the input (per
 * axis). Fails with CORE_EINVAL on a non-finite or out-of-range position, a non-finite time or
 * head position, or a head rotation that is not a unit quaternion (the encoder state is
 * unchanged). */
core_status codec_encode(codec_encoder *enc, const float *xyz, uint64_t seq, const codec_sim_info *sim,
                         bool force_key, codec_buf *out, core_err *err);

/* Frees the encoder's memory and zeroes it. Safe on a zeroed encoder. */
void codec_encoder_free(codec_encoder *enc);

/* Parses and validates the fixed header of data[0..len) (magic, version, codec, flags, counts,
 * step, that the whole payload is present). Does not check the CRC. Pure, any thread. */
core_status codec_peek_header(const uint8_t *data, size_t len, codec_frame_info *info, core_err *err);

/* A decoder holding no keyframe. Never fails. */
void codec_decoder_init(codec_decoder *dec);

/* Decodes one frame into xyz_out (capacity out_floats floats; needs 3 * nstrands_sent * nverts).
 * Keyframes replace the held reference; deltas need the keyframe they name (CORE_ESTATE when it
 * is not held). Any corrupt, truncated or inconsistent frame is rejected (CORE_EFORMAT) with a
 * message; on any failure xyz_out and the held keyframe are unchanged. info may be NULL. */
core_status codec_decode(codec_decoder *dec, const uint8_t *data, size_t len, float *xyz_out,
                         size_t out_floats, codec_frame_info *info, core_err *err);

/* Frees the decoder's memory and zeroes it. Safe on a zeroed decoder. */
void codec_decoder_free(codec_decoder *dec);

#endif
