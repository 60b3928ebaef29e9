/* codec core: the one decoder of strand frames (proto/CODEC.md, format version 3): header, CRC,
 * rigid motion, probability tables, the eight rANS lanes and the raw bits, the reconstruction of
 * groups of 8 strands. The daemon's library wraps it (codec_decode.c: allocation, messages) and
 * web/wasm/build.sh compiles this same source to WebAssembly for the browser (web/codec.js:
 * loading, messages). Freestanding C11 (no libc, no allocation, no globals): the caller owns the
 * state and every region the core reads or writes. One thread at a time uses a state. */
#ifndef CODEC_CODEC_CORE_H
#define CODEC_CODEC_CORE_H

#include <stddef.h>
#include <stdint.h>

#include "codec.h"

/* Readable bytes a frame needs after its end: a corrupt group may read up to 120 bytes per vertex
 * of a strand, plus 64, before the checks after the group refuse it. */
#define CODEC_CORE_SLACK (1u << 19)

/* Failures, in the order a frame is checked (codec_core_error.code; 0 is success). */
enum codec_core_code {
    CODEC_E_SHORT_HEADER = 1, /* a: the frame's length */
    CODEC_E_MAGIC,
    CODEC_E_VERSION,     /* a: the version */
    CODEC_E_CODEC,       /* a: the codec id */
    CODEC_E_FLAGS,       /* a: the flags */
    CODEC_E_REF,         /* the header's seq and ref_seq */
    CODEC_E_TIME,
    CODEC_E_HEAD,        /* index: 0 head position not finite, 1 rotation not finite, 2 rotation
                            not a unit quaternion (a: the bits of its squared norm, binary64) */
    CODEC_E_BOUND,       /* the header's max_error_m */
    CODEC_E_STEP,        /* the header's step and max_error_m */
    CODEC_E_NVERTS,      /* the header's nverts */
    CODEC_E_COUNTS,      /* the header's stride and nstrands_total (stride 1 for a hair mesh) */
    CODEC_E_SENT,        /* a: the strands the header's total and stride give */
    CODEC_E_TOO_MANY,    /* the header's nstrands_sent and nverts */
    CODEC_E_LENGTH,      /* a: the frame's length */
    CODEC_E_CRC,
    CODEC_E_NO_KEY,      /* a delta whose keyframe is not held */
    CODEC_E_KEY_LAYOUT,  /* a delta whose counts or step differ from its keyframe's */
    CODEC_E_NO_MOTION,
    CODEC_E_ROTATION,    /* index: the rotation entry, a: its value */
    CODEC_E_TRANSLATION, /* index: the axis, a: its value */
    CODEC_E_PADDING,     /* index: the motion byte */
    CODEC_E_TABLE_SHORT, /* index: the table */
    CODEC_E_TABLE_VARINT,
    CODEC_E_TABLE_COUNT, /* a: the symbols it lists */
    CODEC_E_TABLE_SYMBOL,
    CODEC_E_TABLE_FREQ,  /* a: the frequency */
    CODEC_E_TABLE_SUM,   /* a: the sum */
    CODEC_E_NO_STREAM,
    CODEC_E_STREAM_LEN,  /* a: the length, b: the payload bytes left */
    CODEC_E_STATE,       /* index: the lane, a: the state */
    CODEC_E_SYMBOL,      /* the rest: index the group's first strand */
    CODEC_E_MODE,
    CODEC_E_OVERRUN,
    CODEC_E_ESCAPE,
    CODEC_E_VALUE,
    CODEC_E_BITS,        /* a: the raw bits there are, b: the bits the frame used */
    CODEC_E_END
};

/* A frame's header (proto/CODEC.md). The layout is fixed (web/codec.js reads it at these
 * offsets): 104 bytes. */
typedef struct codec_core_info {
    uint64_t seq;            /* 0 */
    uint64_t ref_seq;        /* 8 */
    double sim_time;         /* 16 */
    double step;             /* 24 */
    float max_error_m;       /* 32 */
    uint32_t keyframe;       /* 36: 1 or 0 */
    uint32_t nstrands_total; /* 40 */
    uint32_t nstrands_sent;  /* 44 */
    uint32_t nverts;         /* 48 */
    uint32_t stride;         /* 52 */
    uint32_t payload_len;    /* 56 */
    uint32_t codec;          /* 60: CODEC_ID_STRAND or CODEC_ID_HAIRMESH */
    uint64_t sim_step;       /* 64 */
    float head_pos[3];       /* 72: x, y, z */
    float head_rot[4];       /* 84: x, y, z, w */
    uint32_t pad2;           /* 100 */
} codec_core_info;

/* Why the last call failed (fixed layout, 32 bytes). */
typedef struct codec_core_error {
    int32_t code;  /* 0: a codec_core_code */
    uint32_t byte; /* 4: where in the frame the field at fault starts (the entropy coder's words or
                      raw bits where the group failed) */
    uint32_t index;/* 8: a table, lane, motion entry or strand (per code) */
    uint32_t pad;  /* 12 */
    uint64_t a, b; /* 16, 24: values (per code; signed values as their two's complement) */
} codec_core_error;

/* The decoder's state. The hosts read info, key, error, key_valid and key_slot at fixed offsets
 * (0, 104, 208, 240, 244); the rest is the core's. */
typedef struct codec_core {
    codec_core_info info;   /* the header of the last frame parsed (in part when it failed) */
    codec_core_info key;    /* the held keyframe's header */
    codec_core_error error; /* the last failure */
    uint32_t key_valid;     /* 1 while a keyframe is held */
    uint32_t key_slot;      /* the region slot (0 or 1) that holds it */
    int32_t *q[2];          /* lattice slots (codec_core_regions) */
    int16_t *d[2];          /* clamped segment slots */
    int32_t fb[10 * 4096];  /* per table and slot: raw bits << 25 | freq << 12 | (slot - start) */
    uint16_t sinfo[10 * 4096]; /* per table and slot: the symbol's entry (codec_core.c) */
    int32_t res[7 * 32];    /* residual of class c (0..5) from raw bits b at c << 5 | (b & 31) */
    _Alignas(16) int32_t cls[512][3][4]; /* per classes: see codec_core_init */
    int32_t state[8];       /* the lanes' rANS states */
    int32_t motion[12];     /* rho_0..rho_8, t_0..t_2 (deltas) */
    int32_t mode[8];        /* the current group's modes (8 for lanes past the last strand) */
    int32_t root[24];       /* a delta group's roots, axis-major, lane-minor */
    int32_t zero[8];        /* zeros (the first keyframe strand's missing neighbour) */
    uint32_t sym[8 * CODEC_MAX_NVERTS]; /* a group's vertex symbols: raw bits << 25 | entry */
    float dump[4 * CODEC_MAX_NVERTS];   /* where lanes past the last strand write */
    _Alignas(16) int32_t r[CODEC_MAX_NVERTS * 32]; /* a group's residuals */
} codec_core;

/* sizeof(codec_core) (for the WebAssembly host). */
size_t codec_core_size(void);

/* Sets up a state (any memory of codec_core_size() bytes, 16-byte aligned): no keyframe held. */
void codec_core_init(codec_core *k);

/* Forgets the held keyframe. */
void codec_core_reset(codec_core *k);

/* int16 elements of a clamped segment slot for frames of ns strands of nverts vertices. */
size_t codec_core_seg_len(uint32_t ns, uint32_t nverts);

/* Hands the core its slots: two lattice slots of 3 ns nverts int32 and two segment slots of
 * codec_core_seg_len(ns, nverts) int16 each, for the largest frame to come (16-byte aligned). A
 * held keyframe stays in slot key_slot: a caller that moves the slots copies that one. */
void codec_core_regions(codec_core *k, int32_t *q0, int32_t *q1, int16_t *d0, int16_t *d1);

/* zlib's crc32(crc, p, n) (CRC-32, reflected polynomial 0xEDB88320; crc 0 to start). */
uint32_t codec_core_crc32(uint32_t crc, const uint8_t *p, size_t n);

/* Parses and validates the fixed header of a frame of len bytes at p (min(len, 104) bytes
 * readable) into h: magic, version, codec, flags, references, time, head, bound, step, counts, and that
 * the frame has exactly the length the header gives. Not the CRC. Returns 0, or a
 * codec_core_code with e filled in (h then holds the fields read before the one at fault). */
int codec_core_header(codec_core_info *h, codec_core_error *e, const uint8_t *p, size_t len);

/* Checks the frame of len bytes at p before it is decoded: its header (into k->info), its CRC and,
 * for a delta, that the keyframe it names is held and has its layout and step. Returns 0, or a
 * codec_core_code with k->error filled in. */
int codec_core_check(codec_core *k, const uint8_t *p, size_t len);

/* Decodes the frame of len bytes at p, which codec_core_check accepted last (the same bytes, now
 * with CODEC_CORE_SLACK readable bytes after them), into out (3 nstrands_sent nverts floats,
 * float32(q step), strand-major xyz). A keyframe is decoded into the free slots and then held.
 * Returns 0, or a codec_core_code with k->error filled in; then nothing held changes (out may
 * have been written). */
int codec_core_decode(codec_core *k, const uint8_t *p, size_t len, float *out);

#endif
