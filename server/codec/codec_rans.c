/* codec: rANS frequency tables (normalise, serialise, parse) and encoder symbol setup. */
#include <string.h>

#include "codec_rans.h"

uint32_t codec_rans_normalize(const uint32_t *counts, uint32_t n, uint16_t *freq)
{
    uint64_t total = 0;
    uint32_t used = 0, big = 0;
    for (uint32_t i = 0; i < n; i++) {
        total += counts[i];
        if (counts[i]) used = i + 1u;
        if (counts[i] > counts[big]) big = i;
    }
    if (total == 0) {
        memset(freq, 0, n * sizeof *freq);
        return 0;
    }
    int64_t sum = 0;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t f = (uint32_t)(((uint64_t)counts[i] * CODEC_SCALE) / total);
        if (counts[i] && f == 0) f = 1;
        freq[i] = (uint16_t)f;
        sum += f;
    }
    /* Give the rounding difference to the most frequent symbols (at least 1 each stays). */
    while (sum != (int64_t)CODEC_SCALE) {
        if (sum < (int64_t)CODEC_SCALE) {
            freq[big] = (uint16_t)(freq[big] + (uint16_t)((int64_t)CODEC_SCALE - sum));
            sum = CODEC_SCALE;
        } else {
            uint32_t m = 0;
            for (uint32_t i = 1; i < n; i++)
                if (freq[i] > freq[m]) m = i;
            int64_t take = sum - (int64_t)CODEC_SCALE;
            if (take > (int64_t)freq[m] - 1) take = (int64_t)freq[m] - 1;
            freq[m] = (uint16_t)(freq[m] - take);
            sum -= take;
        }
    }
    return used;
}

void codec_rans_sym_init(codec_rans_sym *s, uint32_t start, uint32_t freq)
{
    s->x_max = ((CODEC_RANS_L >> CODEC_SCALE_BITS) << 8) * freq;
    s->cmpl_freq = (uint16_t)(CODEC_SCALE - freq);
    if (freq < 2) {
        /* x / 1 == x: q = x - 1 via the all-ones reciprocal, the bias adds the rest back */
        s->rcp_freq = ~0u;
        s->rcp_shift = 32;
        s->bias = start + CODEC_SCALE - 1u;
    } else {
        uint32_t shift = 0;
        while (freq > (1u << shift)) shift++;
        s->rcp_freq = (uint32_t)(((1ull << (shift + 31u)) + freq - 1u) / freq);
        s->rcp_shift = (uint16_t)(shift + 31u);
        s->bias = start;
    }
}

static uint8_t *put_varint(uint8_t *p, uint32_t v)
{
    while (v >= 0x80u) {
        *p++ = (uint8_t)(v | 0x80u);
        v >>= 7;
    }
    *p++ = (uint8_t)v;
    return p;
}

uint8_t *codec_rans_write_table(uint8_t *p, const uint16_t *freq, uint32_t nsym)
{
    uint32_t used = 0;
    for (uint32_t i = 0; i < nsym; i++) used += freq[i] != 0;
    p = put_varint(p, used);
    uint32_t next = 0;
    for (uint32_t i = 0; i < nsym; i++) {
        if (!freq[i]) continue;
        p = put_varint(p, i - next);
        p = put_varint(p, freq[i]);
        next = i + 1u;
    }
    return p;
}

/* Reads a LEB128 value of at most two bytes (values below 2^14). */
static core_status get_varint(const uint8_t *data, size_t len, size_t *pos, uint32_t *out, core_err *err)
{
    uint32_t v = 0;
    for (uint32_t k = 0; k < 2; k++) {
        if (*pos >= len) return core_fail(err, CORE_EFORMAT, "codec: truncated probability tables");
        uint8_t b = data[(*pos)++];
        v |= (uint32_t)(b & 0x7fu) << (7u * k);
        if (!(b & 0x80u)) {
            *out = v;
            return CORE_OK;
        }
    }
    return core_fail(err, CORE_EFORMAT, "codec: oversized value in probability tables");
}

core_status codec_rans_read_tables(const uint8_t *data, size_t len, size_t *pos, codec_rans_tables *tabs,
                                   uint16_t *slots, core_err *err)
{
    for (uint32_t t = 0; t < CODEC_NTABLES; t++) {
        uint32_t used = 0;
        core_status st = get_varint(data, len, pos, &used, err);
        if (st) return st;
        if (used > CODEC_NSYM)
            return core_fail(err, CORE_EFORMAT, "codec: table %u lists %u symbols (max %u)", t, used, CODEC_NSYM);
        uint16_t *lut = slots + (size_t)t * CODEC_SCALE;
        tabs->nsym[t] = used;
        if (used == 0) {
            for (uint32_t i = 0; i < CODEC_SCALE; i++) lut[i] = 0xffffu;
            continue;
        }
        uint32_t start = 0, next = 0;
        for (uint32_t k = 0; k < used; k++) {
            uint32_t gap = 0, f = 0;
            st = get_varint(data, len, pos, &gap, err);
            if (st) return st;
            st = get_varint(data, len, pos, &f, err);
            if (st) return st;
            if (gap >= CODEC_NSYM - next)
                return core_fail(err, CORE_EFORMAT, "codec: table %u names a symbol beyond %u", t, CODEC_NSYM - 1u);
            uint32_t s = next + gap;
            if (f == 0 || f > CODEC_SCALE - start)
                return core_fail(err, CORE_EFORMAT, "codec: table %u frequency %u invalid (sum must be %u)", t, f,
                                 CODEC_SCALE);
            tabs->freq[t][s] = (uint16_t)f;
            tabs->start[t][s] = (uint16_t)start;
            for (uint32_t i = 0; i < f; i++) lut[start + i] = (uint16_t)s;
            start += f;
            next = s + 1u;
        }
        if (start != CODEC_SCALE)
            return core_fail(err, CORE_EFORMAT, "codec: table %u frequencies sum to %u, not %u", t, start,
                             CODEC_SCALE);
    }
    return CORE_OK;
}

/* One symbol into state x, without branches: at most two renormalisation bytes (x < 2^31 and
 * x_max >= 2^19), both stored, the pointer moved by their count; the state's chain is two
 * selects, two multiplications and an addition. */
static inline uint32_t put(uint32_t x, uint8_t **pp, const codec_rans_sym *s)
{
    const uint32_t xm = s->x_max, x1 = x >> 8, x2 = x >> 16;
    uint32_t v = x >= xm ? x1 : x;
    v = x1 >= xm ? x2 : v;
    uint8_t *p = *pp;
    const uint16_t w = (uint16_t)((x & 0xffu) << 8 | (x1 & 0xffu)); /* p[-2] = x1, p[-1] = x (low bytes) */
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    memcpy(p - 2, &w, 2);
#else
    p[-2] = (uint8_t)w;
    p[-1] = (uint8_t)(w >> 8);
#endif
    *pp = p - ((uint32_t)(x >= xm) + (uint32_t)(x1 >= xm));
    uint32_t q = (uint32_t)(((uint64_t)v * s->rcp_freq) >> s->rcp_shift);
    return v + s->bias + q * s->cmpl_freq;
}

uint8_t *codec_rans_encode(const uint16_t *syms, size_t n, const codec_rans_sym *rs, uint8_t *end, uint32_t x[2])
{
    uint8_t *p = end;
    uint32_t x0 = CODEC_RANS_L, x1 = CODEC_RANS_L;
    size_t i = n;
    if (i & 1u) {
        i--;
        x0 = put(x0, &p, &rs[syms[i]]);
    }
    for (; i >= 2; i -= 2) {
        x1 = put(x1, &p, &rs[syms[i - 1]]);
        x0 = put(x0, &p, &rs[syms[i - 2]]);
    }
    x[0] = x0;
    x[1] = x1;
    return p;
}
