/* sim_vk: marks every float add/sub/mul/div/dot of a SPIR-V module NoContraction, so drivers
 * do not fuse them into FMAs: the shaders then round like the C backend (-ffp-contract=off). */
#include <stdlib.h>
#include <string.h>

#include "sim_vk_internal.h"

enum {
    SPV_MAGIC = 0x07230203u,
    OP_DECORATE = 71,
    OP_TYPE_FIRST = 19, /* OpTypeVoid */
    OP_TYPE_LAST = 39,  /* OpTypeForwardPointer */
    OP_FNEGATE = 127,
    OP_FADD = 129,
    OP_FSUB = 131,
    OP_FMUL = 133,
    OP_FDIV = 136,
    OP_VECTOR_TIMES_SCALAR = 142,
    OP_DOT = 148,
    DEC_NO_CONTRACTION = 42,
};

static bool is_float_arith(uint32_t op)
{
    return op == OP_FNEGATE || op == OP_FADD || op == OP_FSUB || op == OP_FMUL || op == OP_FDIV ||
           op == OP_VECTOR_TIMES_SCALAR || op == OP_DOT;
}

core_status sim_vk_spirv_exact(const uint32_t *code, size_t words, uint32_t **out, size_t *out_words, core_err *err)
{
    *out = NULL;
    *out_words = 0;
    if (words < 5 || code[0] != SPV_MAGIC) return core_fail(err, CORE_EFORMAT, "vulkan: not a SPIR-V module");
    const uint32_t bound = code[3];
    /* pass 1: where the types start, which results to mark, which are marked already */
    size_t insert_at = 0, nmark = 0;
    uint8_t *state = calloc(bound ? bound : 1, 1); /* 1 = float arithmetic result, 2 = already marked */
    if (!state) return core_fail(err, CORE_ENOMEM, "vulkan: out of memory patching SPIR-V");
    for (size_t i = 5; i < words;) {
        uint32_t len = code[i] >> 16, op = code[i] & 0xffffu;
        if (len == 0 || i + len > words) {
            free(state);
            return core_fail(err, CORE_EFORMAT, "vulkan: malformed SPIR-V instruction at word %zu", i);
        }
        if (!insert_at && op >= OP_TYPE_FIRST && op <= OP_TYPE_LAST) insert_at = i;
        if (op == OP_DECORATE && len >= 3 && code[i + 2] == DEC_NO_CONTRACTION && code[i + 1] < bound)
            state[code[i + 1]] = 2;
        if (is_float_arith(op) && len >= 3 && code[i + 2] < bound && state[code[i + 2]] == 0) state[code[i + 2]] = 1;
        i += len;
    }
    for (uint32_t id = 0; id < bound; id++) nmark += state[id] == 1;
    if (!insert_at) {
        free(state);
        return core_fail(err, CORE_EFORMAT, "vulkan: SPIR-V module declares no types");
    }
    size_t total = words + 3 * nmark;
    uint32_t *res = malloc(total * sizeof *res);
    if (!res) {
        free(state);
        return core_fail(err, CORE_ENOMEM, "vulkan: out of memory patching SPIR-V");
    }
    /* pass 2: the decorations go at the end of the annotation section, before the types */
    memcpy(res, code, insert_at * sizeof *res);
    size_t o = insert_at;
    for (uint32_t id = 0; id < bound; id++) {
        if (state[id] != 1) continue;
        res[o++] = (3u << 16) | OP_DECORATE;
        res[o++] = id;
        res[o++] = DEC_NO_CONTRACTION;
    }
    memcpy(res + o, code + insert_at, (words - insert_at) * sizeof *res);
    free(state);
    *out = res;
    *out_words = total;
    return CORE_OK;
}
