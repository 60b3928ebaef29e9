/* codec: the decoder's host side. The decoding itself is the core's (codec_core.c, the same source
 * the browser runs as WebAssembly); this file gives it memory (its state, the lattice and segment
 * slots, a padded copy of the frame, the output before it is handed over) and turns its failures
 * into messages that name the problem, the field and the byte. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "codec_core.h"
#include "codec_internal.h"

void codec_decoder_init(codec_decoder *dec)
{
    if (dec) memset(dec, 0, sizeof *dec);
}

void codec_decoder_free(codec_decoder *dec)
{
    if (!dec) return;
    free(dec->core);
    for (int s = 0; s < 2; s++) {
        free(dec->q[s]);
        free(dec->d[s]);
    }
    free(dec->out);
    free(dec->frame);
    memset(dec, 0, sizeof *dec);
}

/* Where the field at fault lies, for the message: "FIELD, byte N". */
static void where(const codec_core_error *e, const codec_core_info *h, char *buf, size_t cap)
{
    static const char *const fields[] = {
        [CODEC_E_SHORT_HEADER] = "header", [CODEC_E_MAGIC] = "magic", [CODEC_E_VERSION] = "version",
        [CODEC_E_CODEC] = "codec", [CODEC_E_FLAGS] = "flags", [CODEC_E_REF] = "ref_seq",
        [CODEC_E_TIME] = "sim_time", [CODEC_E_HEAD] = "head", [CODEC_E_BOUND] = "max_error_m", [CODEC_E_STEP] = "step",
        [CODEC_E_NVERTS] = "nverts", [CODEC_E_COUNTS] = "stride / nstrands_total",
        [CODEC_E_SENT] = "nstrands_sent", [CODEC_E_TOO_MANY] = "nstrands_sent", [CODEC_E_LENGTH] = "payload_len",
        [CODEC_E_CRC] = "crc32", [CODEC_E_NO_KEY] = "ref_seq", [CODEC_E_KEY_LAYOUT] = "step",
        [CODEC_E_NO_MOTION] = "motion", [CODEC_E_ROTATION] = "motion", [CODEC_E_TRANSLATION] = "motion",
        [CODEC_E_PADDING] = "motion", [CODEC_E_NO_STREAM] = "rans_len", [CODEC_E_STREAM_LEN] = "rans_len",
        [CODEC_E_STATE] = "rans states", [CODEC_E_BITS] = "raw bits", [CODEC_E_END] = "rans",
    };
    if (e->code >= CODEC_E_TABLE_SHORT && e->code <= CODEC_E_TABLE_SUM)
        snprintf(buf, cap, "table %u, byte %u", e->index, e->byte);
    else if (e->code >= CODEC_E_SYMBOL && e->code <= CODEC_E_VALUE) {
        uint32_t last = e->index + 7u < h->nstrands_sent ? e->index + 7u : h->nstrands_sent - 1u;
        snprintf(buf, cap, "strands %u-%u, byte %u", e->index, last, e->byte);
    } else
        snprintf(buf, cap, "%s, byte %u", fields[e->code], e->byte);
}

/* The message of the core's failure e on the frame of len bytes whose header h holds (as far as
 * it was read); CORE_ESTATE when the keyframe a delta needs is not held, else CORE_EFORMAT. */
static core_status report(const codec_core_error *e, const codec_core_info *h, size_t len, core_err *err)
{
    char at[64];
    where(e, h, at, sizeof at);
    const unsigned long long seq = (unsigned long long)h->seq, ref = (unsigned long long)h->ref_seq;
    const unsigned long long a = (unsigned long long)e->a, b = (unsigned long long)e->b;
    const core_status st = CORE_EFORMAT;
    switch (e->code) {
    case CODEC_E_SHORT_HEADER:
        return core_fail(err, st, "codec: truncated header (%zu bytes, need %u) [%s]", len, CODEC_HEADER_SIZE, at);
    case CODEC_E_MAGIC: return core_fail(err, st, "codec: bad magic (not a strand frame) [%s]", at);
    case CODEC_E_VERSION:
        return core_fail(err, st, "codec: unsupported format version %llu (this decoder reads %u) [%s]", a,
                         CODEC_VERSION, at);
    case CODEC_E_CODEC: return core_fail(err, st, "codec: unknown codec id %llu [%s]", a, at);
    case CODEC_E_FLAGS: return core_fail(err, st, "codec: unknown flags 0x%02llx [%s]", a, at);
    case CODEC_E_REF:
        return core_fail(err, st, "codec: reference sequence %llu invalid for %s %llu [%s]", ref,
                         h->keyframe ? "keyframe" : "delta frame", seq, at);
    case CODEC_E_TIME: return core_fail(err, st, "codec: sim time is not finite [%s]", at);
    case CODEC_E_HEAD:
        if (e->index == 2) {
            double norm2;
            memcpy(&norm2, &e->a, sizeof norm2);
            return core_fail(err, st, "codec: head rotation is not a unit quaternion (squared norm %.9g, not within %g of 1) [%s]",
                             norm2, CODEC_HEAD_NORM_TOL, at);
        }
        return core_fail(err, st, "codec: head %s is not finite [%s]", e->index ? "rotation" : "position", at);
    case CODEC_E_BOUND:
        return core_fail(err, st, "codec: error bound %g m outside [%g, %g] [%s]", (double)h->max_error_m,
                         (double)CODEC_MIN_ERROR, (double)CODEC_MAX_ERROR, at);
    case CODEC_E_STEP:
        return core_fail(err, st, "codec: quantization step %g m does not meet bound %g m [%s]", h->step,
                         (double)h->max_error_m, at);
    case CODEC_E_NVERTS:
        return core_fail(err, st, "codec: %u vertices per strand outside [2, %u] [%s]", h->nverts,
                         CODEC_MAX_NVERTS, at);
    case CODEC_E_COUNTS:
        if (h->codec == CODEC_ID_HAIRMESH && h->stride >= 1 && h->nstrands_total >= 1)
            return core_fail(err, st, "codec: a hair mesh frame has stride 1, not %u [%s]", h->stride, at);
        return core_fail(err, st, "codec: stride %u / strand count %u must be positive [%s]", h->stride,
                         h->nstrands_total, at);
    case CODEC_E_SENT:
        return core_fail(err, st, "codec: %u strands sent but %u strands at stride %u give %llu [%s]",
                         h->nstrands_sent, h->nstrands_total, h->stride, a, at);
    case CODEC_E_TOO_MANY:
        return core_fail(err, st, "codec: %u x %u vertices exceed the limit %u [%s]", h->nstrands_sent, h->nverts,
                         CODEC_MAX_VERTICES, at);
    case CODEC_E_LENGTH:
        return core_fail(err, st, "codec: frame is %zu bytes but its header says %llu (%s) [%s]", len,
                         (unsigned long long)CODEC_HEADER_SIZE + h->payload_len,
                         len < (size_t)CODEC_HEADER_SIZE + h->payload_len ? "truncated" : "trailing bytes", at);
    case CODEC_E_CRC: return core_fail(err, st, "codec: CRC mismatch (frame %llu corrupted) [%s]", seq, at);
    case CODEC_E_NO_KEY:
        return core_fail(err, CORE_ESTATE, "codec: frame %llu needs keyframe %llu, which is not held [%s]", seq, ref,
                         at);
    case CODEC_E_KEY_LAYOUT:
        return core_fail(err, st, "codec: frame %llu does not match its keyframe's layout or step [%s]", seq, at);
    case CODEC_E_NO_MOTION: return core_fail(err, st, "codec: truncated payload (no motion) [%s]", at);
    case CODEC_E_ROTATION:
        return core_fail(err, st, "codec: invalid rigid motion (rotation entry %u is %lld, outside [-16384, 16384]) [%s]",
                         e->index, (long long)e->a, at);
    case CODEC_E_TRANSLATION:
        return core_fail(err, st, "codec: invalid rigid motion (translation %u is %lld, outside [-2^28, 2^28]) [%s]",
                         e->index, (long long)e->a, at);
    case CODEC_E_PADDING:
        return core_fail(err, st, "codec: invalid rigid motion (padding byte %u is not zero) [%s]", e->index, at);
    case CODEC_E_TABLE_SHORT: return core_fail(err, st, "codec: truncated probability tables [%s]", at);
    case CODEC_E_TABLE_VARINT: return core_fail(err, st, "codec: oversized value in probability tables [%s]", at);
    case CODEC_E_TABLE_COUNT:
        return core_fail(err, st, "codec: table %u lists %llu symbols (max %u) [%s]", e->index, a, CODEC_NSYM, at);
    case CODEC_E_TABLE_SYMBOL:
        return core_fail(err, st, "codec: table %u names a symbol beyond %u [%s]", e->index, CODEC_NSYM - 1u, at);
    case CODEC_E_TABLE_FREQ:
        return core_fail(err, st, "codec: table %u frequency %llu invalid (sum must be %u) [%s]", e->index, a,
                         CODEC_SCALE, at);
    case CODEC_E_TABLE_SUM:
        return core_fail(err, st, "codec: table %u frequencies sum to %llu, not %u [%s]", e->index, a, CODEC_SCALE, at);
    case CODEC_E_NO_STREAM: return core_fail(err, st, "codec: truncated payload (no stream length) [%s]", at);
    case CODEC_E_STREAM_LEN:
        return core_fail(err, st,
                         "codec: entropy stream length %llu invalid (even, at least %u, at most the %llu payload "
                         "bytes left) [%s]",
                         a, CODEC_RANS_HEAD, b, at);
    case CODEC_E_STATE:
        return core_fail(err, st, "codec: invalid entropy coder state %llu in lane %u (below 2^16) [%s]", a, e->index,
                         at);
    case CODEC_E_SYMBOL:
        return core_fail(err, st, "codec: corrupt entropy-coded data (a symbol from an unused probability table) [%s]",
                         at);
    case CODEC_E_MODE:
        return core_fail(err, st, "codec: corrupt entropy-coded data (prediction mode out of range) [%s]", at);
    case CODEC_E_OVERRUN: return core_fail(err, st, "codec: corrupt entropy-coded data (rANS stream overrun) [%s]", at);
    case CODEC_E_ESCAPE:
        return core_fail(err, st, "codec: corrupt raw bits (escape exponent above %u) [%s]", CODEC_ESC_MAX, at);
    case CODEC_E_VALUE: return core_fail(err, st, "codec: corrupt frame (decoded coordinate out of range) [%s]", at);
    case CODEC_E_BITS: return core_fail(err, st, "codec: raw bit stream is %llu bits, frame used %llu [%s]", a, b, at);
    default:
        return core_fail(err, st,
                         "codec: entropy stream does not end in the initial states with every word read [%s]", at);
    }
}

/* The core's header record as codec.h's. */
static codec_frame_info frame_info(const codec_core_info *h)
{
    codec_sim_info sim = { .sim_time = h->sim_time, .sim_step = h->sim_step };
    memcpy(sim.head_pos, h->head_pos, sizeof sim.head_pos);
    memcpy(sim.head_rot, h->head_rot, sizeof sim.head_rot);
    return (codec_frame_info){ .seq = h->seq, .ref_seq = h->ref_seq, .sim = sim, .step = h->step,
                               .max_error_m = h->max_error_m, .keyframe = h->keyframe != 0,
                               .codec_id = h->codec,
                               .nstrands_total = h->nstrands_total, .nstrands_sent = h->nstrands_sent,
                               .nverts = h->nverts, .stride = h->stride, .payload_len = h->payload_len,
                               .frame_len = (size_t)CODEC_HEADER_SIZE + h->payload_len };
}

core_status codec_peek_header(const uint8_t *data, size_t len, codec_frame_info *info, core_err *err)
{
    if (!data || !info) return core_fail(err, CORE_EINVAL, "codec: NULL frame or info");
    codec_core_info h;
    codec_core_error e;
    memset(&h, 0, sizeof h);
    if (codec_core_header(&h, &e, data, len)) return report(&e, &h, len, err);
    *info = frame_info(&h);
    return CORE_OK;
}

/* Grows *p to n elements of size sz, keeping its contents. */
static bool grow(void **p, size_t sz, size_t n)
{
    void *q = realloc(*p, n * sz);
    if (!q) return false;
    *p = q;
    return true;
}

/* Makes the decoder's memory hold a frame of len bytes of the layout of h, keeping the held
 * keyframe (its slots grow by realloc, which keeps their contents). */
static core_status reserve(codec_decoder *dec, const codec_frame_info *h, size_t len, core_err *err)
{
    const size_t nq = (size_t)h->nstrands_sent * h->nverts * 3u, seg = codec_core_seg_len(h->nstrands_sent, h->nverts);
    if (dec->q_cap < nq) {
        for (int s = 0; s < 2; s++)
            if (!grow((void **)&dec->q[s], sizeof *dec->q[s], nq))
                return core_fail(err, CORE_ENOMEM, "codec: out of memory for %zu coordinates", nq);
        if (!grow((void **)&dec->out, sizeof *dec->out, nq))
            return core_fail(err, CORE_ENOMEM, "codec: out of memory for %zu coordinates", nq);
        dec->q_cap = nq;
    }
    if (dec->d_cap < seg) {
        for (int s = 0; s < 2; s++)
            if (!grow((void **)&dec->d[s], sizeof *dec->d[s], seg))
                return core_fail(err, CORE_ENOMEM, "codec: out of memory for %zu segments", seg);
        dec->d_cap = seg;
    }
    codec_core_regions(dec->core, dec->q[0], dec->q[1], dec->d[0], dec->d[1]);
    const size_t need = len + CODEC_CORE_SLACK;
    if (dec->frame_cap < need) {
        free(dec->frame);
        dec->frame = calloc(need, 1);
        dec->frame_cap = dec->frame ? need : 0;
        if (!dec->frame) return core_fail(err, CORE_ENOMEM, "codec: out of memory for a %zu-byte frame", len);
    }
    return CORE_OK;
}

/* The core's state, made on first use. */
static core_status core_state(codec_decoder *dec, core_err *err)
{
    if (dec->core) return CORE_OK;
    const size_t size = (codec_core_size() + 63u) & ~(size_t)63u;
    dec->core = aligned_alloc(64, size);
    if (!dec->core) return core_fail(err, CORE_ENOMEM, "codec: out of memory for the decoder's state");
    codec_core_init(dec->core);
    return CORE_OK;
}

core_status codec_decode(codec_decoder *dec, const uint8_t *data, size_t len, float *xyz_out,
                         size_t out_floats, codec_frame_info *info, core_err *err)
{
    if (!dec || !xyz_out) return core_fail(err, CORE_EINVAL, "codec: NULL decoder or output");
    if (!data) return core_fail(err, CORE_EINVAL, "codec: NULL frame or info");
    core_status st = core_state(dec, err);
    if (st) return st;
    codec_core *k = dec->core;
    if (codec_core_check(k, data, len)) return report(&k->error, &k->info, len, err);
    const codec_frame_info h = frame_info(&k->info);
    const size_t nq = (size_t)h.nstrands_sent * h.nverts * 3u;
    if (out_floats < nq)
        return core_fail(err, CORE_EINVAL, "codec: output holds %zu floats, frame needs %zu", out_floats, nq);
    st = reserve(dec, &h, len, err);
    if (st) return st;
    memcpy(dec->frame, data, len);
    memset(dec->frame + len, 0, 16);
    if (codec_core_decode(k, dec->frame, len, dec->out)) return report(&k->error, &k->info, len, err);
    memcpy(xyz_out, dec->out, nq * sizeof *xyz_out);
    if (info) *info = h;
    return CORE_OK;
}
