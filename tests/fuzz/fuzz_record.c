/* fuzz_record: libFuzzer target for app_rec_read, the --replay file reader, with the daemon's
 * own tables (sim_param_table, the animation presets, the procedural style names). */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "app/app_anim.h"
#include "app/app_rec.h"
#include "groom/groom.h"
#include "sim/sim.h"

#define FUZZ_NSTYLES 3

/* Reads one file; any outcome but CORE_OK or CORE_EFORMAT with a reason (or CORE_ENOMEM) is a
 * bug (the sanitizers catch memory errors and undefined behaviour). */
static void read_one(const uint8_t *data, size_t size)
{
    size_t nparams;
    const core_param_info *params = sim_param_table(&nparams);
    const char *styles[FUZZ_NSTYLES];
    for (int i = 0; i < FUZZ_NSTYLES; i++) styles[i] = groom_style_name((groom_style)i);
    const proto_parser p = { params, nparams, app_preset_names, APP_PRESET_COUNT, styles, FUZZ_NSTYLES };
    app_rec_start s;
    app_rec *v;
    size_t n;
    core_err err = { "" };
    core_status st = app_rec_read(data, size, &p, &s, &v, &n, &err);
    if (st == CORE_OK) {
        if (n == 0 || v[n - 1].kind != APP_REC_END) __builtin_trap();
        free(v);
    } else if ((st != CORE_EFORMAT && st != CORE_ENOMEM) || err.msg[0] == '\0') {
        __builtin_trap();
    }
}

/* One input = one record file, read as it is and with every record's crc32 rewritten (so that
 * mutations reach the field decoders). */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    read_one(data, size);
    uint8_t *c = malloc(size + 1);
    if (!c) return 0;
    memcpy(c, data, size);
    size_t off = APP_REC_FILE_HEADER;
    while (off + APP_REC_FRAME + 4 <= size) {
        uint32_t len = c[off] | (uint32_t)c[off + 1] << 8 | (uint32_t)c[off + 2] << 16 | (uint32_t)c[off + 3] << 24;
        if (len > size - off - APP_REC_FRAME - 4) break;
        size_t end = off + APP_REC_FRAME + len;
        uint32_t crc = (uint32_t)crc32(0, c + off + 4, (uInt)(end - off - 4));
        for (int i = 0; i < 4; i++) c[end + i] = (uint8_t)(crc >> (8 * i));
        off = end + 4;
    }
    read_one(c, size);
    free(c);
    return 0;
}
