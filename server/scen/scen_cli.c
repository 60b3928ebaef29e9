/* scen: the command lines of `strandcastc run SCRIPT.json` and `strandcastc check`. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../core/cli.h"
#include "../proto/proto.h"
#include "scen.h"

static const char *const RUN_USAGE =
    "usage: strandcastc run [--host H] [--port N] [--room NAME] [--json] SCRIPT.json\n"
    "Connects to a running strandcastd (subprotocol " PROTO_SUBPROTOCOL "), reads its hello and runs the\n"
    "script's steps in order: send a message (at a wall time, a sim time or a step), wait for the\n"
    "reply to an id and expect its type or error code, wait for frames, a sim time or a step, expect a\n"
    "value in the hello, the parameters or the state, check invariants on the frames. Prints one line\n"
    "per step. The script format: tests/scenarios/README.md.\n"
    "  --host H      address of the daemon (default 127.0.0.1)\n"
    "  --port N      its port (default 7681)\n"
    "  --room NAME   the room to join, at /rooms/NAME (default: the room \"default\" at /)\n"
    "  --json        one JSON object per step, {\"step\":I,\"kind\":..,\"ok\":..,\"detail\":..,\"seen\":..},\n"
    "                then {\"summary\":true,\"ok\":..,\"failed_step\":I|null,...}\n"
    "Exit status: 0 when every expectation held, 1 at the first step that failed (named, with what\n"
    "was seen) or when the connection fails, 2 for bad flags or a bad script (the step index and\n"
    "field are named).\n";

static const char *const CHECK_USAGE =
    "usage: strandcastc check [--host H] [--port N] [--room NAME] [--frames N | --seconds S] [--max-stretch R]\n"
    "                         [--max-depth M] [--root-tolerance M] [--min-fps F] [--max-gap-ms MS] [--json]\n"
    "Connects to a running strandcastd, fetches the groom data (rest lengths and roots) from the\n"
    "hello's groom.url on the same host and port, and checks invariants on the frames it receives:\n"
    "every position finite; every segment within R (relative) of its strand's rest length; no vertex\n"
    "deeper than M inside the analytic colliders of the hello (in the head frame, moving with the\n"
    "head); roots within the tolerance of the rest roots under the head transform each frame's\n"
    "header carries (presets and other clients' motion included); at least F frames/s; no gap\n"
    "between two frames over MS. The codec's error bound of each frame is added to the bounds. A\n"
    "failure names the frame (seq), strand and vertex and the measured value; groom data that cannot\n"
    "be fetched or does not match the hello fails with \"groom data: ...\". A bound below 0 turns its\n"
    "check off.\n"
    "  --host H, --port N      the daemon (default 127.0.0.1:7681)\n"
    "  --room NAME             the room to join, at /rooms/NAME (default: the room \"default\" at /)\n"
    "  --frames N              frames to check (default 120)\n"
    "  --seconds S             check for S seconds instead\n"
    "  --max-stretch R         default 0.02\n"
    "  --max-depth M           metres, default 0.002\n"
    "  --root-tolerance M      metres, default 0.001\n"
    "  --min-fps F             default 0 (not checked)\n"
    "  --max-gap-ms MS         default 1000\n"
    "  --json                  one JSON object with the figures\n"
    "Exit status: 0 when every invariant held, 1 when one did not or the connection failed, 2 for\n"
    "bad flags.\n";

enum {
    OPT_HOST = 256,
    OPT_PORT,
    OPT_ROOM,
    OPT_JSON,
    OPT_FRAMES,
    OPT_SECONDS,
    OPT_STRETCH,
    OPT_DEPTH,
    OPT_ROOT,
    OPT_FPS,
    OPT_GAP
};

static const struct option options[] = {
    { "host", required_argument, NULL, OPT_HOST },
    { "port", required_argument, NULL, OPT_PORT },
    { "room", required_argument, NULL, OPT_ROOM },
    { "json", no_argument, NULL, OPT_JSON },
    { "frames", required_argument, NULL, OPT_FRAMES },
    { "seconds", required_argument, NULL, OPT_SECONDS },
    { "max-stretch", required_argument, NULL, OPT_STRETCH },
    { "max-depth", required_argument, NULL, OPT_DEPTH },
    { "root-tolerance", required_argument, NULL, OPT_ROOT },
    { "min-fps", required_argument, NULL, OPT_FPS },
    { "max-gap-ms", required_argument, NULL, OPT_GAP },
    { "help", no_argument, NULL, 'h' },
    { NULL, 0, NULL, 0 },
};

/* The flags both subcommands read; check_step receives the check's bounds (NULL for run). */
static int parse(const char *prog, const char *usage, int argc, char **argv, scen_run_desc *d, scen_step *check_step)
{
    core_cli_begin();
    char flag[64];
    int opt, status;
    while ((opt = core_cli_next(prog, argc, argv, options, flag, sizeof flag, &status)) > 0) {
        if (opt == 'h') {
            fputs(usage, stdout);
            return -1;
        }
        const char *v = optarg;
        unsigned long long u = 0;
        int rc = 0;
        if (!check_step && opt >= OPT_FRAMES) return core_cli_bad(prog, flag, NULL, "is a flag of strandcastc check");
        switch (opt) {
        case OPT_HOST: d->host = v; break;
        case OPT_ROOM:
            if (!proto_room_valid(v)) return core_cli_bad(prog, flag, v, "is not a room name: 1..64 letters, digits, '-' or '_'");
            d->room = v;
            break;
        case OPT_JSON: d->json = true; break;
        case OPT_PORT:
            if (!(rc = core_cli_u64(prog, flag, v, 1, 65535, &u))) d->port = (int)u;
            break;
        case OPT_FRAMES:
            if (!(rc = core_cli_u64(prog, flag, v, 1, 100000000ull, &u))) check_step->count = (double)u;
            break;
        case OPT_SECONDS: rc = core_cli_f64(prog, flag, v, 0.001, 86400.0, &check_step->seconds); break;
        case OPT_STRETCH: rc = core_cli_f64(prog, flag, v, -1.0, 1e6, &check_step->check.max_stretch); break;
        case OPT_DEPTH: rc = core_cli_f64(prog, flag, v, -1.0, 1e6, &check_step->check.max_depth); break;
        case OPT_ROOT: rc = core_cli_f64(prog, flag, v, -1.0, 1e6, &check_step->check.root_tolerance); break;
        case OPT_FPS: rc = core_cli_f64(prog, flag, v, 0.0, 1e6, &check_step->check.min_fps); break;
        case OPT_GAP: rc = core_cli_f64(prog, flag, v, -1.0, 1e9, &check_step->check.max_gap_ms); break;
        }
        if (rc) return rc;
    }
    return status;
}

int scen_cli_run(int argc, char **argv)
{
    const char *prog = "strandcastc run";
    scen_run_desc d = { 0 };
    bool help = false;
    for (int i = 1; i < argc; i++) help |= !strcmp(argv[i], "--help") || !strcmp(argv[i], "-h");
    /* the last argument is the script unless it is a flag or the value of one */
    bool value = argc >= 3 && (!strcmp(argv[argc - 2], "--host") || !strcmp(argv[argc - 2], "--port") ||
                               !strcmp(argv[argc - 2], "--room"));
    if (!help && (argc < 2 || argv[argc - 1][0] == '-' || value))
        return core_cli_bad(prog, "SCRIPT.json", NULL, "missing: give the script as the last argument");
    int rc = parse(prog, RUN_USAGE, help ? argc : argc - 1, argv, &d, NULL);
    if (rc) return rc < 0 ? 0 : rc;
    scen_script s;
    core_err err;
    if (scen_script_load(&s, argv[argc - 1], &err) != CORE_OK) {
        fprintf(stderr, "%s: %s: %s\n", prog, argv[argc - 1], err.msg);
        return CORE_CLI_USAGE;
    }
    rc = scen_run(&d, &s);
    scen_script_free(&s);
    return rc;
}

int scen_cli_check(int argc, char **argv)
{
    scen_run_desc d = { 0 };
    scen_step st;
    memset(&st, 0, sizeof st);
    int rc = parse("strandcastc check", CHECK_USAGE, argc, argv, &d, &st);
    if (rc) return rc < 0 ? 0 : rc;
    if (st.count > 0 && st.seconds > 0) return core_cli_bad("strandcastc check", "--seconds", NULL, "give --frames or --seconds");
    if (st.count == 0 && st.seconds == 0) st.count = 120;
    st.kind = SCEN_CHECK;
    st.timeout_ms = st.seconds > 0 ? 0 : 10000.0 + st.count * 200.0;
    scen_script s = { .name = "check", .steps = &st, .nsteps = 1 };
    return scen_run(&d, &s);
}
