/* codec_abi: a small, stable C ABI over the strand-frame decoder for other languages (Python's
 * ctypes, cffi): an opaque handle, plain arguments and int status codes, and the header of the
 * last frame read back through one accessor function per field, so that no caller mirrors a C
 * struct. Built into the shared library libstrandcast_codec.so (CMakeLists.txt), which exports
 * these functions only, under the symbol version STRANDCAST_CODEC_1 (codec_abi.map).
 *
 * Compatibility: adding a function (a new header field is one new accessor) keeps
 * CODEC_ABI_VERSION; changing or removing one raises it. A scalar field NAME is read as
 * `T codec_abi_NAME(const codec_abi_decoder *)`; a vector field of n values as
 * `void codec_abi_NAME(const codec_abi_decoder *, T out[n])`. Field names are proto/CODEC.md's. */
#ifndef CODEC_CODEC_ABI_H
#define CODEC_CODEC_ABI_H

#include <stddef.h>
#include <stdint.h>

#define CODEC_ABI_VERSION 1u

/* A decoder and the header of the last frame it read. Opaque. */
typedef struct codec_abi_decoder codec_abi_decoder;

/* CODEC_ABI_VERSION of this library. Pure, any thread. */
uint32_t codec_abi_version(void);

/* The strand frame format version this library reads (CODEC_VERSION). Pure, any thread. */
uint32_t codec_abi_format_version(void);

/* The stable name of a status code the functions below return (core_status_name: "ok",
 * "invalid_argument", "out_of_memory", "bad_format", "bad_state", ...; "unknown" for any other
 * number); static storage. Pure, any thread. */
const char *codec_abi_status_name(int status);

/* A new decoder holding no keyframe; its header reads as zeros until a frame is read. NULL when
 * out of memory. The caller owns it and frees it with codec_abi_decoder_free; one thread at a
 * time uses it. */
codec_abi_decoder *codec_abi_decoder_new(void);

/* Frees d and everything it holds. NULL is a no-op. */
void codec_abi_decoder_free(codec_abi_decoder *d);

/* Reads and validates the fixed header of the frame data[0..len) (caller-owned, read only; the
 * CRC is not checked) and holds it for the accessors, without decoding or changing the held
 * keyframe. Returns 0, or a status (codec_abi_status_name) with codec_abi_message saying why;
 * on failure the header held is unchanged. */
int codec_abi_peek(codec_abi_decoder *d, const uint8_t *data, size_t len);

/* Decodes the frame data[0..len) (caller-owned, read only) into out: out_floats floats, which
 * must be at least 3 * nstrands_sent * nverts (strand-major xyz; peek the header first to size
 * it). Keyframes replace the held keyframe; a delta needs the keyframe it names ("bad_state"
 * when it is not held). A corrupt, truncated or inconsistent frame is "bad_format". Returns 0
 * and holds the frame's header, or a status with codec_abi_message saying why; on failure out,
 * the held keyframe and the header held are unchanged. */
int codec_abi_decode(codec_abi_decoder *d, const uint8_t *data, size_t len, float *out, size_t out_floats);

/* The message of d's last failure ("" when none failed yet); owned by d, valid until its next
 * call. */
const char *codec_abi_message(const codec_abi_decoder *d);

/* The fields of the header held (proto/CODEC.md); 0 before the first frame was read. */
uint64_t codec_abi_seq(const codec_abi_decoder *d);
uint64_t codec_abi_ref_seq(const codec_abi_decoder *d);
int codec_abi_keyframe(const codec_abi_decoder *d);         /* 1 keyframe, 0 delta */
double codec_abi_sim_time(const codec_abi_decoder *d);      /* s */
uint64_t codec_abi_sim_step(const codec_abi_decoder *d);    /* the simulation's step counter */
double codec_abi_step(const codec_abi_decoder *d);          /* quantization step, m */
float codec_abi_max_error_m(const codec_abi_decoder *d);    /* per-axis error bound, m */
uint32_t codec_abi_nstrands_total(const codec_abi_decoder *d);
uint32_t codec_abi_nstrands_sent(const codec_abi_decoder *d);
uint32_t codec_abi_nverts(const codec_abi_decoder *d);
uint32_t codec_abi_stride(const codec_abi_decoder *d);
/* 1 for a strand frame, 2 for a hair mesh frame (its "strands" are the mesh's columns, its
 * "vertices" their layers: proto/CODEC.md, "Hair mesh frames"). */
uint32_t codec_abi_codec_id(const codec_abi_decoder *d);
uint32_t codec_abi_payload_len(const codec_abi_decoder *d);
uint64_t codec_abi_frame_len(const codec_abi_decoder *d);   /* header + payload bytes */
/* The head transform the simulation used for the frame's positions (world frame): position x, y,
 * z in metres, and orientation, a unit quaternion x, y, z, w; out is caller-owned. A NULL d, or
 * no frame read yet, gives zeros. */
void codec_abi_head_position(const codec_abi_decoder *d, float out[3]);
void codec_abi_head_orientation(const codec_abi_decoder *d, float out[4]);

#endif
