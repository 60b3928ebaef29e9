/* Strand frame decoding kernel (proto/CODEC.md, format version 2) in WebAssembly: entropy decoding,
 * prediction and dequantization of one frame, for web/codec.js. Freestanding C (no libc), built by
 * web/wasm/build.sh into web/codec_kernel_wasm.js. A frame is decoded a group of 8 strands at a
 * time: the group's symbols (8 rANS lanes, vertex by vertex across the lanes) become residuals
 * (kern.r, vertex-major: a delta's axis-major and lane-minor, a keyframe's lane-major with the
 * x, y, z of a lane together), then the group's strands are rebuilt: a delta frame's 8 strands at
 * once with WebAssembly SIMD (2 x i32x4 per axis), a keyframe's one after another (each predicts
 * from the one before, x, y, z in one i32x4). All arithmetic wraps modulo 2^32 (-fwrapv), as the
 * format's reference decoders do. */
#include <stdint.h>
#include <wasm_simd128.h>

#define NTAB 10          /* tables 0 mode, 1 root, 2 first segment, 3..8 body, T_IDLE */
#define T_IDLE 9         /* the lanes past the last strand: keep their state, no raw bits */
#define INFO_SLOW 512    /* an escaped axis */
#define INFO_NEXT 0xf000 /* the next vertex's table << 12 */
#define INFO_UNUSED 0x9fff /* every slot of an unused table: INFO_SLOW, next table T_IDLE */
#define MAX_NVERTS 4096
#define QMAX 67108863    /* |lattice coordinate| <= 2^26 - 1 */

enum {
    K_OK = 0, K_BAD_SYMBOL = -1, K_BAD_MODE = -2, K_OVERRUN = -3, K_BAD_ESCAPE = -4,
    K_BAD_VALUE = -5, K_BITS_SHORT = -6, K_BAD_END = -7, K_BITS_LEFT = -8
};

/* The kernel's fixed state, at an offset of the memory chosen by codec.js (kern_offset). */
typedef struct kern {
    int32_t fb[NTAB * 4096];      /* per table and slot: bits << 25 | freq << 12 | (slot - start) */
    uint16_t info[NTAB * 4096];   /* per table and slot: the symbol's INFO entry (codec.js) */
    int32_t res[7 * 32];          /* residual of class c (0..5) from raw bits b at c << 5 | (b & 31); c = 6: 0 */
    v128_t cls[512][3];           /* per classes c_x | c_y << 3 | c_z << 6 (each 0..5): see kern_init */
    int32_t state[10];            /* the 8 lanes' rANS states; after a frame: words read, raw bits used */
    int32_t motion[12];           /* rho_0..rho_8, t_0..t_2 (deltas) */
    int32_t list[2 * 9 * 344];    /* the tables as read: table << 16 | INFO, freq << 12 | start */
    int32_t mode[8];              /* the current group's modes (8 for lanes past the last strand) */
    int32_t root[24];             /* a delta group's roots, axis-major, lane-minor */
    int32_t zero[8];              /* zeros (the first keyframe strand's missing neighbour; read 4 at 0 and 3) */
    uint32_t sym[8 * MAX_NVERTS]; /* a group's vertex symbols in coding order: raw bits << 25 | INFO */
    float dump[4 * MAX_NVERTS];   /* where the output of lanes past the last strand goes */
    int32_t r[MAX_NVERTS * 32] __attribute__((aligned(16))); /* residuals: delta [v][axis][lane], key [v][lane][4] */
} kern;

/* Byte offset of a field of kern that codec.js fills or reads (0 list, 1 state, 2 motion), or
 * (3) the size of kern. (Conditionals, not a switch, which could become a table in the module's
 * data: the module must put nothing in memory above its stack.) */
__attribute__((export_name("kern_offset"))) int kern_offset(int which)
{
    int list = (int)__builtin_offsetof(kern, list), state = (int)__builtin_offsetof(kern, state);
    int motion = (int)__builtin_offsetof(kern, motion), size = (int)sizeof(kern);
    return which == 0 ? list : which == 1 ? state : which == 2 ? motion : size;
}

/* Fills the constant lookups of a fresh kern (zeroed memory): the residuals (res, and cls for a
 * keyframe's three axes at once) and T_IDLE, whose every slot keeps the state (freq 4096,
 * slot - start = slot), reads no raw bits, has classes 0 and names T_IDLE next. */
__attribute__((export_name("kern_init"))) void kern_init(kern *k)
{
    for (int c = 1; c < 6; c++) {
        for (int b = 0; b < 32; b++) {
            int f = b & ((1 << c) - 1), m = (1 << (c - 1)) | (f >> 1);
            k->res[(c << 5) | b] = f & 1 ? -m : m;
        }
    }
    /* for classes c (x, y, z; lane 3 unused) whose raw bits start at offsets o = (0, c_x, c_x + c_y):
     * bits o..o+15 of a 32-bit window w are (w * 2^(16 - o)) >> 16 (mod 2^32); then the mask of c
     * bits, and m's leading one 2^(c - 1) (0 for c = 0) */
    for (int f = 0; f < 512; f++) {
        int c[3] = { f & 7, (f >> 3) & 7, (f >> 6) & 7 };
        if (c[0] > 5 || c[1] > 5 || c[2] > 5) continue;
        int o[3] = { 0, c[0], c[0] + c[1] };
        k->cls[f][0] = wasm_i32x4_make(65536 >> o[0], 65536 >> o[1], 65536 >> o[2], 0);
        k->cls[f][1] = wasm_i32x4_make((1 << c[0]) - 1, (1 << c[1]) - 1, (1 << c[2]) - 1, 0);
        k->cls[f][2] = wasm_i32x4_make(c[0] ? 1 << (c[0] - 1) : 0, c[1] ? 1 << (c[1] - 1) : 0,
                                       c[2] ? 1 << (c[2] - 1) : 0, 0);
    }
    for (int s = 0; s < 4096; s++) {
        k->info[T_IDLE * 4096 + s] = T_IDLE << 12;
        k->fb[T_IDLE * 4096 + s] = (4096 << 12) | s;
    }
}

/* Fills fb and info from the n entries of list; every slot of tables 0..8 must be covered (an
 * unused table by one entry INFO_UNUSED, freq 4096, start 0). */
__attribute__((export_name("kern_tables"))) void kern_tables(kern *k, int n)
{
    for (int e = 0; e < n; e++) {
        uint32_t a = (uint32_t)k->list[2 * e], b = (uint32_t)k->list[2 * e + 1];
        uint32_t t = a >> 16, v = a & 0xffff, f = b >> 12, st = b & 4095;
        uint32_t bits = t > 0 && v != INFO_UNUSED ? (v & 7) + ((v >> 3) & 7) + ((v >> 6) & 7) : 0;
        uint32_t s = (t << 12) + st;
        for (uint32_t i = 0; i < f; i++) {
            k->info[s + i] = (uint16_t)v;
            k->fb[s + i] = (int32_t)((bits << 25) | (f << 12) | i);
        }
    }
}

static inline uint64_t load64(const uint8_t *p)
{
    uint64_t w;
    __builtin_memcpy(&w, p, 8);
    return w;
}

static inline uint32_t load16(const uint8_t *p)
{
    uint16_t w;
    __builtin_memcpy(&w, p, 2);
    return w;
}

/* The readers: rANS word position, raw bits (from bits, bp read). */
typedef struct reader {
    const uint8_t *rp;
    const uint8_t *bits;
    uint32_t bp;
} reader;

/* The residuals of a vertex symbol with INFO entry f whose raw bits start at bp of bits, any
 * class (escapes included), to r[0], r[as], r[2 as]. Returns the bit position after them, or
 * K_BAD_SYMBOL (f from an unused table) or K_BAD_ESCAPE. */
__attribute__((noinline)) static int64_t slow_symbol(const kern *k, uint32_t f, const uint8_t *bits, uint32_t bp,
                                                     int32_t *r, int as)
{
    if (f == INFO_UNUSED) return K_BAD_SYMBOL;
    for (int ax = 0; ax < 3; ax++) {
        uint32_t c = (f >> (3 * ax)) & 7;
        uint64_t w = load64(bits + (bp >> 3)) >> (bp & 7);
        int32_t v;
        if (c < 6) {
            v = k->res[(c << 5) | (uint32_t)(w & 31)];
            bp += c;
        } else {
            /* escape: e - 5 (5 bits), the sign, then the e bits of m below its leading one */
            uint32_t e = (uint32_t)(w & 31);
            if (e > 24) return K_BAD_ESCAPE;
            e += 5;
            uint32_t neg = (uint32_t)(w >> 5) & 1;
            bp += 6;
            w = load64(bits + (bp >> 3)) >> (bp & 7);
            int32_t m = (int32_t)((1u << e) | ((uint32_t)w & ((1u << e) - 1)));
            bp += e;
            v = neg ? -m : m;
        }
        r[as * ax] = v;
    }
    return bp;
}

/* slow_symbol for a keyframe's raw pass (to r[0..2]), without branches on the classes or the
 * bits: the escapes of keyframes are common and unpredictable. */
static inline __attribute__((always_inline)) int64_t key_slow_symbol(const kern *k, uint32_t f, const uint8_t *bits,
                                                                     uint32_t bp, int32_t *r)
{
    if (f == INFO_UNUSED) return K_BAD_SYMBOL;
    uint32_t bad = 0;
    _Pragma("clang loop unroll(full)")
    for (int ax = 0; ax < 3; ax++) {
        uint32_t c = (f >> (3 * ax)) & 7;
        uint64_t w = load64(bits + (bp >> 3)) >> (bp & 7);
        /* an escape: e - 5 (5 bits), the sign, then the e bits of m below its leading one (e - 5
         * above 24 is refused; e is taken modulo 32 only to keep the shifts defined), and the
         * table lookup of any other class (res has a row of zeros for c = 6) */
        uint32_t lo = (uint32_t)w & 31, e = (lo + 5) & 31, esc = c == 6;
        uint32_t m = (1u << e) | ((uint32_t)(w >> 6) & ((1u << e) - 1));
        uint32_t neg = 0u - ((uint32_t)(w >> 5) & 1);
        int32_t ve = (int32_t)((m ^ neg) - neg), vc = k->res[(c << 5) | lo];
        bad |= esc & (lo > 24);
        r[ax] = esc ? ve : vc;
        bp += esc ? 6 + e : c;
    }
    return bad ? (int64_t)K_BAD_ESCAPE : (int64_t)bp;
}

/* The residuals of a vertex symbol with INFO entry f (bits 0..15) and nb raw bits (when no axis
 * is escaped) at the readers' bp, to rr[0], rr[RAXIS], rr[2 RAXIS]; on an error returns its code. */
#define RAW_SYMBOL(f, nb, rr)                                                       \
    do {                                                                            \
        if ((f) & INFO_SLOW) {                                                      \
            int64_t nb_ = slow_symbol(k, f, bits, bp, rr, RAXIS);                   \
            if (nb_ < 0) return (int)nb_;                                           \
            bp = (uint32_t)nb_;                                                     \
        } else {                                                                    \
            uint32_t w = (uint32_t)(load64(bits + (bp >> 3)) >> (bp & 7));          \
            uint32_t c0 = (f) & 7, c1 = ((f) >> 3) & 7, c2 = ((f) >> 6) & 7;        \
            (rr)[0] = k->res[(c0 << 5) | (w & 31)];                                 \
            w >>= c0;                                                               \
            (rr)[RAXIS] = k->res[(c1 << 5) | (w & 31)];                             \
            w >>= c1;                                                               \
            (rr)[2 * RAXIS] = k->res[(c2 << 5) | (w & 31)];                         \
            bp += nb;                                                               \
        }                                                                           \
    } while (0)

/* One rANS step of a lane whose state X is x | table << 44 (table: the one to read the symbol
 * with): i = the slot's table index; X becomes the next x (table bits clear); the word reader
 * advances. */
#define RANS_STEP(X, i, fb)                                                         \
    do {                                                                            \
        uint32_t x_ = (uint32_t)(X);                                                \
        i = (uint32_t)((X) >> 32) | (x_ & 4095);                                    \
        fb = (uint32_t)k->fb[i];                                                    \
        x_ = ((fb >> 12) & 8191) * (x_ >> 12) + (fb & 4095);                        \
        uint32_t nr_ = x_ < 65536, xw_ = (x_ << 16) | load16(rp);                   \
        x_ = nr_ ? xw_ : x_;                                                        \
        rp += nr_ << 1;                                                             \
        X = x_;                                                                     \
    } while (0)

/* The rANS step of lane L's vertex symbol: its INFO entry to f and its table slot to fb, the
 * next table into X##L. */
#define LANE_SYMBOL(L, f, fb)                                                       \
    do {                                                                            \
        uint32_t i;                                                                 \
        RANS_STEP(X##L, i, fb);                                                     \
        f = k->info[i];                                                             \
        X##L |= (uint64_t)(f & INFO_NEXT) << 32;                                    \
    } while (0)

/* A vertex symbol of lane L at the vertex whose residuals start at rv (RLANE, RAXIS: the strides
 * of a lane and an axis there): residuals to rv[RLANE L + RAXIS axis], the next table into X##L. */
#define VERTEX_LANE(L)                                                              \
    do {                                                                            \
        uint32_t f, fb;                                                             \
        LANE_SYMBOL(L, f, fb);                                                      \
        RAW_SYMBOL(f, fb >> 25, rv + RLANE * (L));                                  \
    } while (0)

/* The rANS step of lane L's vertex symbol: its raw-bit count << 25 | INFO entry to sp[L], the
 * next table into X##L. */
#define RANS_LANE(L)                                                                \
    do {                                                                            \
        uint32_t f, fb;                                                             \
        LANE_SYMBOL(L, f, fb);                                                      \
        sp[L] = (fb & 0xfe000000u) | f;                                             \
    } while (0)

/* The raw bits of lane L's symbol sp[L] (RANS_LANE) at a keyframe's vertex whose residuals start
 * at rv: x, y, z to rv[4 L + 0..2] (and 0 to rv[4 L + 3] unless an axis is escaped); without an
 * escape, the three axes at once (kern.cls). */
#define KEY_RAW_LANE(L)                                                             \
    do {                                                                            \
        uint32_t e = sp[L];                                                         \
        int32_t *rr = rv + 4 * (L);                                                 \
        if (e & INFO_SLOW) {                                                        \
            int64_t nb_ = key_slow_symbol(k, e & 0xffff, bits, bp, rr);             \
            if (nb_ < 0) return (int)nb_;                                           \
            bp = (uint32_t)nb_;                                                     \
        } else {                                                                    \
            uint32_t w_;                                                            \
            __builtin_memcpy(&w_, bits + (bp >> 3), 4);                             \
            const v128_t *cd = k->cls[e & 511];                                     \
            v128_t b_ = wasm_i32x4_mul(wasm_i32x4_splat(w_ >> (bp & 7)), cd[0]);     \
            b_ = wasm_v128_and(wasm_u32x4_shr(b_, 16), cd[1]);                      \
            v128_t s_ = wasm_v128_and(b_, wasm_i32x4_splat(1));                     \
            v128_t m_ = wasm_v128_or(wasm_u32x4_shr(b_, 1), cd[2]);                 \
            wasm_v128_store(rr, wasm_i32x4_add(wasm_v128_xor(m_, wasm_i32x4_neg(s_)), s_)); \
            bp += e >> 25;                                                          \
        }                                                                           \
    } while (0)

/* The mode symbol of lane L to k->mode[L]; X##L then reads its next symbol with table t, or
 * T_IDLE for a lane past the last strand. */
#define MODE_LANE(L, t)                                                             \
    do {                                                                            \
        uint32_t i, fb;                                                             \
        RANS_STEP(X##L, i, fb);                                                     \
        k->mode[L] = k->info[i];                                                    \
        X##L |= (uint64_t)(n > (L) ? (t) : T_IDLE) << 44;                           \
    } while (0)

/* The state of lane L from k->state, to read table t (T_IDLE for a lane past the last strand). */
#define LANE_STATE(L, t) ((uint32_t)k->state[L] | (uint64_t)(n > (L) ? (t) : T_IDLE) << 44)

/* Decodes the symbols of one group of n strands (lanes from n on idle) of a keyframe (key: a
 * constant) or a delta: the modes to k->mode (below 3 or 4; idle lanes 8), the residuals to k->r
 * (a keyframe's [v][lane][x, y, z, lane 3], a delta's [v][axis][lane]). A keyframe's vertex
 * symbols take two passes, each with few live values: the rANS steps (to k->sym; a lane that
 * meets an unused table goes on idle), then the raw bits with the escapes (common in keyframes)
 * decoded without branches; a delta's take one pass. The readers continue from rd and the lane
 * states in k->state and are left there. Returns K_OK or the K_* code of an error (that of the
 * first bad symbol in coding order; rd->rp then is after the modes, rd->bp unchanged). */
static inline __attribute__((always_inline)) int group_symbols(kern *k, reader *rd, int n, int nverts, const int key)
{
    const int RLANE = key ? 4 : 1, RAXIS = key ? 1 : 8, RVERT = key ? 32 : 24, nmodes = key ? 3 : 4;
    const uint8_t *rp = rd->rp, *bits = rd->bits;
    uint32_t bp = rd->bp;
    uint64_t X0 = LANE_STATE(0, 0), X1 = LANE_STATE(1, 0), X2 = LANE_STATE(2, 0), X3 = LANE_STATE(3, 0);
    uint64_t X4 = LANE_STATE(4, 0), X5 = LANE_STATE(5, 0), X6 = LANE_STATE(6, 0), X7 = LANE_STATE(7, 0);
    MODE_LANE(0, 1); MODE_LANE(1, 1); MODE_LANE(2, 1); MODE_LANE(3, 1);
    MODE_LANE(4, 1); MODE_LANE(5, 1); MODE_LANE(6, 1); MODE_LANE(7, 1);
    rd->rp = rp;
    /* a mode out of range (or from an unused table) ends the frame before its vertices */
    for (int l = 0; l < n; l++) {
        int f = k->mode[l];
        if (f >= nmodes) return f == INFO_UNUSED ? K_BAD_SYMBOL : K_BAD_MODE;
    }
    for (int l = n; l < 8; l++) k->mode[l] = 8;
    int32_t *rv = k->r, *rend = k->r + RVERT * nverts;
    if (key) {
        uint32_t *sp = k->sym, *send = k->sym + 8 * nverts;
        for (; sp < send; sp += 8) {
            RANS_LANE(0); RANS_LANE(1); RANS_LANE(2); RANS_LANE(3);
            RANS_LANE(4); RANS_LANE(5); RANS_LANE(6); RANS_LANE(7);
        }
        for (sp = k->sym; sp < send; sp += 8, rv += RVERT) {
            KEY_RAW_LANE(0); KEY_RAW_LANE(1); KEY_RAW_LANE(2); KEY_RAW_LANE(3);
            KEY_RAW_LANE(4); KEY_RAW_LANE(5); KEY_RAW_LANE(6); KEY_RAW_LANE(7);
        }
    } else {
        for (; rv < rend; rv += RVERT) {
            VERTEX_LANE(0); VERTEX_LANE(1); VERTEX_LANE(2); VERTEX_LANE(3);
            VERTEX_LANE(4); VERTEX_LANE(5); VERTEX_LANE(6); VERTEX_LANE(7);
        }
    }
    k->state[0] = (int32_t)X0; k->state[1] = (int32_t)X1; k->state[2] = (int32_t)X2;
    k->state[3] = (int32_t)X3; k->state[4] = (int32_t)X4; k->state[5] = (int32_t)X5;
    k->state[6] = (int32_t)X6; k->state[7] = (int32_t)X7;
    rd->rp = rp;
    rd->bp = bp;
    return K_OK;
}

/* group_symbols of a keyframe's group and of a delta's, as functions of their own. */
__attribute__((noinline)) static int key_symbols(kern *k, reader *rd, int n, int nverts)
{
    return group_symbols(k, rd, n, nverts, 1);
}

__attribute__((noinline)) static int delta_symbols(kern *k, reader *rd, int n, int nverts)
{
    return group_symbols(k, rd, n, nverts, 0);
}

/* Negative when q is outside [-QMAX, QMAX]. */
static inline int32_t out_of_range(int32_t q)
{
    return (q + QMAX) | (QMAX - q);
}

/* float32(q * step) of the 4 lanes of q. */
static inline v128_t to_float(v128_t q, v128_t st)
{
    v128_t lo = wasm_f32x4_demote_f64x2_zero(wasm_f64x2_mul(wasm_f64x2_convert_low_i32x4(q), st));
    v128_t hi = wasm_f32x4_demote_f64x2_zero(
        wasm_f64x2_mul(wasm_f64x2_convert_low_i32x4(wasm_i32x4_shuffle(q, q, 2, 3, 2, 3)), st));
    return wasm_i32x4_shuffle(lo, hi, 0, 1, 4, 5);
}

/* The vertex (x, y, z: 4 lanes each) of 4 lanes to o0..o3 at v floats on; with 16-byte stores
 * (the fourth float lands where the lane's next vertex goes) unless last (the lane's last
 * vertex: 12 bytes exactly). */
static inline void store_vertex(v128_t x, v128_t y, v128_t z, float *o0, float *o1, float *o2, float *o3, int v,
                                int last)
{
    v128_t t0 = wasm_i32x4_shuffle(x, y, 0, 4, 1, 5), t1 = wasm_i32x4_shuffle(x, y, 2, 6, 3, 7);
    v128_t l0 = wasm_i32x4_shuffle(t0, z, 0, 1, 4, 4), l1 = wasm_i32x4_shuffle(t0, z, 2, 3, 5, 5);
    v128_t l2 = wasm_i32x4_shuffle(t1, z, 0, 1, 6, 6), l3 = wasm_i32x4_shuffle(t1, z, 2, 3, 7, 7);
    if (!last) {
        wasm_v128_store(o0 + v, l0);
        wasm_v128_store(o1 + v, l1);
        wasm_v128_store(o2 + v, l2);
        wasm_v128_store(o3 + v, l3);
    } else {
        wasm_v128_store64_lane(o0 + v, l0, 0);
        wasm_v128_store32_lane(o0 + v + 2, l0, 2);
        wasm_v128_store64_lane(o1 + v, l1, 0);
        wasm_v128_store32_lane(o1 + v + 2, l1, 2);
        wasm_v128_store64_lane(o2 + v, l2, 0);
        wasm_v128_store32_lane(o2 + v + 2, l2, 2);
        wasm_v128_store64_lane(o3 + v, l3, 0);
        wasm_v128_store32_lane(o3 + v + 2, l3, 2);
    }
}

static inline v128_t vhalf(v128_t x)
{
    return wasm_i32x4_shr(wasm_i32x4_add(x, wasm_v128_and(wasm_i32x4_shr(x, 1), wasm_i32x4_splat(1))), 1);
}

/* The x, y, z lanes of v (the fourth is not stored) to p: 16 bytes (the fourth lands where the
 * next vertex goes) unless last (the strand's last vertex: 12 bytes exactly). */
static inline void store_xyz(void *p, v128_t v, int last)
{
    if (!last) {
        wasm_v128_store(p, v);
    } else {
        wasm_v128_store64_lane(p, v, 0);
        wasm_v128_store32_lane((char *)p + 8, v, 2);
    }
}

/* A strand's clamped segment d = clamp15(the x, y, z lanes of s) to pd, where delta_lanes reads
 * it: (d_0, d_1) at pd[0..2), (d_2, 1) at pd[16..18). Saturation to Int16 clamps the top. */
static inline void store_seg(int16_t *pd, v128_t s)
{
    v128_t d = wasm_i32x4_shuffle(wasm_i32x4_max(s, wasm_i32x4_splat(-32767)), wasm_i32x4_splat(1), 0, 1, 2, 4);
    v128_t h = wasm_i16x8_narrow_i32x4(d, d);
    wasm_v128_store32_lane(pd, h, 0);
    wasm_v128_store32_lane(pd + 16, h, 1);
}

/* Vertices 2 on of a keyframe strand (see rebuild_key; kind as there, constant per call), the
 * x, y, z of a vertex in lanes 0..2 of one vector (lane 3 is not used). Returns the unsigned
 * maximum of |q| (per lane; |-2^31| counts as 2^31). */
static inline __attribute__((always_inline)) v128_t key_body(const int32_t *r, const int32_t *pn, int32_t *pc,
                                                             float *po, int16_t *pd, int nverts, v128_t st, v128_t a,
                                                             v128_t b, v128_t n, const int kind)
{
    v128_t bad = wasm_i32x4_splat(0), e = b;
    for (int v = 2; v < nverts; v++) {
        v128_t q, rv = wasm_v128_load(r + 32 * v);
        if (kind == 1) {
            v128_t kn = n;
            n = wasm_v128_load(pn + 3 * v);
            q = wasm_i32x4_add(a, wasm_i32x4_sub(n, kn));
        } else if (kind == 3 && v > 2) {
            q = wasm_i32x4_add(a, vhalf(wasm_i32x4_sub(a, e)));
        } else {
            q = wasm_i32x4_sub(wasm_i32x4_add(a, a), b);
        }
        q = wasm_i32x4_add(q, rv);
        bad = wasm_u32x4_max(bad, wasm_i32x4_abs(q));
        int last = v == nverts - 1;
        store_xyz(pc + 3 * v, q, last);
        store_xyz(po + 3 * v, to_float(q, st), last);
        store_seg(pd + 32 * v, wasm_i32x4_sub(q, a));
        e = b;
        b = a;
        a = q;
    }
    return bad;
}

/* Rebuilds keyframe strand j (lane l of its group; mode < 3) from the residuals in k->r (lane l's
 * at 4 l of each vertex's 32): the lattice coordinates to pc (nverts vertices), float32(q * step)
 * to po, its clamped segments to pd (the group's in the layout of segments_idle, plus 2 l). The neighbour N is the
 * previous strand (at pc - 3 nverts, already rebuilt), zeros for the first. Root N[0] + R;
 * vertex 1 P[0] + N[1] - N[0]; from vertex 2 mode 1 with a neighbour P[v-1] + N[v] - N[v-1],
 * mode 2 linear at vertex 2 and then smooth linear P[v-1] + half(P[v-1] - P[v-3]), else linear
 * 2 P[v-1] - P[v-2]. Returns the OR of the range checks (negative: a coordinate out of range). */
static int32_t rebuild_key(const kern *k, int l, int mode, int j, int32_t *pc, float *po, int16_t *pd, int nverts,
                           double step)
{
    const int32_t *pn = j > 0 ? pc - 3 * nverts : k->zero;
    const int32_t *r = k->r + 4 * l;
    v128_t st = wasm_f64x2_splat(step);
    v128_t k0 = wasm_v128_load(pn), n = wasm_v128_load(pn + 3);
    v128_t b = wasm_i32x4_add(k0, wasm_v128_load(r));
    v128_t a = wasm_i32x4_add(wasm_i32x4_add(b, wasm_i32x4_sub(n, k0)), wasm_v128_load(r + 32));
    v128_t bad = wasm_u32x4_max(wasm_i32x4_abs(b), wasm_i32x4_abs(a));
    int last = nverts == 2;
    store_xyz(pc, b, 0);
    store_xyz(po, to_float(b, st), 0);
    store_xyz(pc + 3, a, last);
    store_xyz(po + 3, to_float(a, st), last);
    wasm_v128_store32_lane(pd, wasm_i32x4_splat(0), 0); /* vertex 0 */
    wasm_v128_store32_lane(pd + 16, wasm_i32x4_splat(0), 0);
    store_seg(pd + 32, wasm_i32x4_sub(a, b));
    /* kind: 1 neighbour, 2 linear, 3 linear once, then smooth linear */
    if (mode == 1 && j > 0) bad = wasm_u32x4_max(bad, key_body(r, pn, pc, po, pd, nverts, st, a, b, n, 1));
    else if (mode == 2) bad = wasm_u32x4_max(bad, key_body(r, pn, pc, po, pd, nverts, st, a, b, n, 3));
    else bad = wasm_u32x4_max(bad, key_body(r, pn, pc, po, pd, nverts, st, a, b, n, 2));
    return wasm_i32x4_bitmask(wasm_u32x4_gt(bad, wasm_i32x4_splat(QMAX))) & 7 ? -1 : 0;
}

/* Vertices 1 on of a delta group's 8 strands at once (the roots are in k->root), from the
 * moved segments S[v] = (rho d[v] + 8192) >> 14 of the held keyframe's clamped segments d (pd:
 * the group's, laid out as segments_idle says): vertex 1 and mode 0 P[v-1] + S[v], mode 1 that plus w = P[v-1] -
 * P[v-2] - S[v-1] (the sum of the residuals since vertex 1), mode 2 linear, mode 3 linear at
 * vertex 2 and then smooth linear; plus the residual. general: 0 when every lane's mode is 0 or
 * 1. o[l]: lane l's output (float32(q * step)). Returns the OR of the range checks. */
static inline __attribute__((always_inline)) int32_t delta_lanes(const kern *k, const int16_t *pd, int nverts,
                                                                 double step, float *const *o, int general)
{
    const int32_t *m = k->motion;
    /* per axis the pairs (rho_0, rho_1) and (rho_2, 8192) of its row, as i16x8 */
    v128_t r01[3], r2c[3];
    _Pragma("clang loop unroll(full)")
    for (int ax = 0; ax < 3; ax++) {
        r01[ax] = wasm_i32x4_splat((m[3 * ax] & 0xffff) | (m[3 * ax + 1] << 16));
        r2c[ax] = wasm_i32x4_splat((m[3 * ax + 2] & 0xffff) | (8192 << 16));
    }
    v128_t st = wasm_f64x2_splat(step), lim = wasm_i32x4_splat(QMAX);
    v128_t a[6], b[6], e[6], w[6], mw[2], m2[2], mlo[2], mseg[2], mlin[2], bad = wasm_i32x4_splat(0);
    _Pragma("clang loop unroll(full)")
    for (int h = 0; h < 2; h++) {
        v128_t md = wasm_v128_load(k->mode + 4 * h);
        mw[h] = wasm_i32x4_eq(md, wasm_i32x4_splat(1));
        m2[h] = wasm_i32x4_eq(md, wasm_i32x4_splat(2));
        mlo[h] = wasm_i32x4_lt(md, wasm_i32x4_splat(2));
        mseg[h] = wasm_i32x4_splat(-1);
        mlin[h] = wasm_i32x4_splat(0);
    }
    _Pragma("clang loop unroll(full)")
    for (int i = 0; i < 6; i++) {
        a[i] = wasm_v128_load(k->root + 4 * i);
        b[i] = a[i];
        e[i] = a[i];
        w[i] = wasm_i32x4_splat(0);
    }
    float *o0 = o[0], *o1 = o[1], *o2 = o[2], *o3 = o[3], *o4 = o[4], *o5 = o[5], *o6 = o[6], *o7 = o[7];
    const int32_t *rv = k->r + 24;
    for (int v = 1; v < nverts; v++, rv += 24) {
        const int16_t *dv = pd + 32 * v;
        v128_t d01[2], d2c[2];
        _Pragma("clang loop unroll(full)")
        for (int h = 0; h < 2; h++) {
            d01[h] = wasm_v128_load(dv + 8 * h);
            d2c[h] = wasm_v128_load(dv + 16 + 8 * h);
        }
        _Pragma("clang loop unroll(full)")
        for (int ax = 0; ax < 3; ax++) {
            _Pragma("clang loop unroll(full)")
            for (int h = 0; h < 2; h++) {
                int i = 2 * ax + h;
                v128_t s = wasm_i32x4_add(wasm_i32x4_dot_i16x8(d01[h], r01[ax]), wasm_i32x4_dot_i16x8(d2c[h], r2c[ax]));
                v128_t r = wasm_v128_load(rv + 4 * i);
                v128_t q = wasm_i32x4_add(wasm_i32x4_add(a[i], wasm_i32x4_shr(s, 14)), w[i]);
                if (general) {
                    v128_t lin = wasm_i32x4_sub(wasm_i32x4_add(a[i], a[i]), b[i]);
                    v128_t sm = wasm_i32x4_add(a[i], vhalf(wasm_i32x4_sub(a[i], e[i])));
                    q = wasm_v128_bitselect(q, wasm_v128_bitselect(lin, sm, mlin[h]), mseg[h]);
                    e[i] = b[i];
                    b[i] = a[i];
                }
                q = wasm_i32x4_add(q, r);
                w[i] = wasm_i32x4_add(w[i], wasm_v128_and(r, mw[h]));
                bad = wasm_v128_or(bad, wasm_v128_or(wasm_i32x4_add(q, lim), wasm_i32x4_sub(lim, q)));
                a[i] = q;
            }
        }
        int last = v == nverts - 1;
        store_vertex(to_float(a[0], st), to_float(a[2], st), to_float(a[4], st), o0, o1, o2, o3, 3 * v, last);
        store_vertex(to_float(a[1], st), to_float(a[3], st), to_float(a[5], st), o4, o5, o6, o7, 3 * v, last);
        if (general) {
            _Pragma("clang loop unroll(full)")
            for (int h = 0; h < 2; h++) {
                mseg[h] = mlo[h];
                /* linear at vertex 2 for modes 2 and 3, then for mode 2 only */
                mlin[h] = v == 1 ? wasm_v128_not(mlo[h]) : m2[h];
            }
        }
    }
    return wasm_i32x4_bitmask(bad) ? -1 : 0;
}

/* Rebuilds the n strands from g of a delta group (lanes past n: zero residuals, roots and
 * segments, output to k->dump): the roots one after another (K'[0] + R, plus N[0] - KN'[0] after
 * the first strand; gn, gkn: the previous strand's root and moved root, which this group's last
 * strand replaces), then delta_lanes. keyq: the held keyframe's lattice; pd: its clamped
 * segments for this group. Returns the OR of the range checks. */
static int32_t rebuild_delta_group(kern *k, int g, int n, int nverts, const int32_t *keyq, const int16_t *pd,
                                   float *out, double step, int32_t *gn, int32_t *gkn)
{
    const int32_t *m = k->motion;
    int32_t bad = 0;
    float *o[8];
    int general = 0;
    for (int l = 0; l < 8; l++) {
        if (l >= n) {
            k->root[l] = k->root[8 + l] = k->root[16 + l] = 0;
            o[l] = k->dump;
            continue;
        }
        int j = g + l;
        const int32_t *pk = keyq + 3 * nverts * j;
        double kx = pk[0], ky = pk[1], kz = pk[2];
        int32_t lm[3];
        for (int ax = 0; ax < 3; ax++) {
            /* the moved root K'[0] (exact in binary64, clamped to |K'| < 2^26) */
            double s = (double)m[3 * ax] * kx + (double)m[3 * ax + 1] * ky + (double)m[3 * ax + 2] * kz + 8192.0;
            int32_t x = (int32_t)__builtin_floor(s / 16384.0) + m[9 + ax];
            lm[ax] = x < -QMAX ? -QMAX : x > QMAX ? QMAX : x;
        }
        o[l] = out + 3 * nverts * j;
        for (int ax = 0; ax < 3; ax++) {
            int32_t b = lm[ax] + k->r[8 * ax + l];
            if (j > 0) b += gn[ax] - gkn[ax];
            gn[ax] = b;
            gkn[ax] = lm[ax];
            bad |= out_of_range(b);
            k->root[8 * ax + l] = b;
            o[l][ax] = (float)(b * step);
        }
        general |= k->mode[l] >= 2;
    }
    /* root[] is axis-major, lane-minor: a[2 ax + h] = root[8 ax + 4 h ..] */
    if (general) return bad | delta_lanes(k, pd, nverts, step, o, 1);
    return bad | delta_lanes(k, pd, nverts, step, o, 0);
}

/* The clamped segments of a keyframe lie per group of 8 strands and vertex in 32 Int16, laid out
 * for i32x4.dot_i16x8_s (delta_lanes): lane l's (d_0, d_1) at 2 l, its (d_2, 1) at 16 + 2 l,
 * where d = clamp15(L[v] - L[v-1]); vertex 0 and lanes past the last strand are 0 (rebuild_key
 * writes a strand's). Zeros lanes n..7 of a group's pd. */
static void segments_idle(int16_t *pd, int n, int nverts)
{
    for (int v = 0; v < nverts; v++) {
        for (int l = n; l < 8; l++) {
            pd[32 * v + 2 * l] = pd[32 * v + 2 * l + 1] = 0;
            pd[32 * v + 16 + 2 * l] = pd[32 * v + 17 + 2 * l] = 0;
        }
    }
}

/* Decodes the ns strands of nverts vertices of a frame whose bytes lie in memory: the rANS words
 * from wpos to wend (even length), the raw bits from bits (bavail bits; the memory after them
 * must hold 120 nverts + 64 readable bytes, as a corrupt frame may make a group read that far
 * before the checks after the group refuse it). The lane states (k->state, the initial states),
 * the tables (kern_init, kern_tables) and for a delta the motion (k->motion) must be filled in.
 * Writes float32(q * step) to out; a keyframe writes its lattice to curq and its clamped
 * segments to dcur (segments_idle's layout); a delta reads the held keyframe's at keyq and dkey. Returns
 * K_OK or the K_* code of the first error (k->state[8], [9] then hold the words read and the raw
 * bits used). */
__attribute__((export_name("kern_frame"))) int kern_frame(kern *k, int key, int ns, int nverts,
                                                         const uint8_t *wpos, const uint8_t *wend,
                                                         const uint8_t *bits, uint32_t bavail,
                                                         const int32_t *keyq, int32_t *curq, float *out,
                                                         const int16_t *dkey, int16_t *dcur, double step)
{
    reader rd = { wpos, bits, 0 };
    int per = 3 * nverts;
    int32_t gn[3] = { 0, 0, 0 }, gkn[3] = { 0, 0, 0 };
    for (int g = 0; g < ns; g += 8) {
        int n = ns - g < 8 ? ns - g : 8;
        int rc = key ? key_symbols(k, &rd, n, nverts) : delta_symbols(k, &rd, n, nverts);
        k->state[8] = (int32_t)(rd.rp - wpos);
        k->state[9] = (int32_t)rd.bp;
        if (rc < 0) return rc;
        if (rd.rp > wend) return K_OVERRUN;
        if (rd.bp > bavail) return K_BITS_SHORT;
        int32_t bad = 0;
        if (key) {
            int16_t *pd = dcur + 4 * nverts * g;
            for (int l = 0; l < n; l++) {
                int j = g + l;
                bad |= rebuild_key(k, l, k->mode[l], j, curq + per * j, out + per * j, pd + 2 * l, nverts, step);
            }
            segments_idle(pd, n, nverts);
        } else {
            bad = rebuild_delta_group(k, g, n, nverts, keyq, dkey + 4 * nverts * g, out, step, gn, gkn);
        }
        if (bad < 0) return K_BAD_VALUE;
    }
    if (rd.rp != wend) return K_BAD_END;
    for (int l = 0; l < 8; l++) {
        if (k->state[l] != 65536) return K_BAD_END;
    }
    if (bavail - rd.bp >= 8) return K_BITS_LEFT;
    return K_OK;
}
