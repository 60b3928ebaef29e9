/* fuzz_groom: libFuzzer targets for the file loaders from bytes. Built once per loader with
 * FUZZ_LOADER set to 1 (.tfx), 2 (.hair), 3 (.obj), 4 (.tfxmesh) or 5 (layered hair mesh .obj). */
#include <stdint.h>
#include <string.h>

#include "groom/groom.h"

#ifndef FUZZ_LOADER
#error "define FUZZ_LOADER"
#endif

/* A refusal must be CORE_EFORMAT (or CORE_ENOMEM) with a message. */
static void check_refusal(core_status st, const core_err *err)
{
    if (st != CORE_EFORMAT && st != CORE_ENOMEM) __builtin_trap();
    if (err->msg[0] == '\0') __builtin_trap();
}

#if FUZZ_LOADER <= 2
/* Loads the image resampled to nverts (0 = the file's count); a loaded groom must be finite. */
static void load_groom(const uint8_t *data, size_t size, uint32_t nverts)
{
    core_err err;
    core_groom g;
    memset(&g, 0, sizeof g);
    core_status st = FUZZ_LOADER == 1 ? groom_load_tfx(data, size, nverts, &g, &err)
                                      : groom_load_hair(data, size, nverts, &g, &err);
    if (st != CORE_OK) {
        check_refusal(st, &err);
        return;
    }
    if (nverts && g.nverts != nverts) __builtin_trap();
    for (size_t i = 0; i < (size_t)g.nstrands * g.nverts * 3; i++)
        if (!(g.pos[i] == g.pos[i])) __builtin_trap();
    core_groom_free(&g);
}
#endif

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
#if FUZZ_LOADER <= 2
    load_groom(data, size, 0);
    load_groom(data, size, 3);
#elif FUZZ_LOADER == 5
    core_err err;
    core_hairmesh m;
    core_status st = groom_hairmesh_load_obj(data, size, &m, &err);
    if (st != CORE_OK) {
        check_refusal(st, &err);
        return 0;
    }
    core_groom g; /* a loaded mesh traces */
    if (groom_from_hairmesh(&m, 2, 5, &g, &err) != CORE_OK) __builtin_trap();
    core_groom_free(&g);
    core_hairmesh_free(&m);
#else
    core_err err;
    core_mesh m;
    memset(&m, 0, sizeof m);
    core_status st = FUZZ_LOADER == 3 ? groom_mesh_load_obj(data, size, &m, &err) : groom_mesh_load_tfxmesh(data, size, &m, &err);
    if (st == CORE_OK) core_mesh_free(&m);
    else check_refusal(st, &err);
#endif
    return 0;
}
