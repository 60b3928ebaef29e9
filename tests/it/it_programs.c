/* Integration tests: the programs' flags (strandcastd) and the command-line client (strandcastc). */
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "it.h"

void test_flags(void **state)
{
    const config *cfg = *state;
    static char out[16384];
    const char *help[] = { "--help", NULL };
    assert_int_equal(run_capture(cfg->exe, help, out, sizeof out), 0);
    static const char *const flags[] = { "--groom", "--collider", "--strands", "--verts", "--seed", "--backend", "--device", "--threads",
                                         "--listen", "--port", "--web", "--assets", "--rate", "--max-error",
                                         "--keyframe-interval", "--client-buffer", "--ping-interval", "--ping-timeout",
                                         "--max-clients", "--token-file", "--insecure-open", "--allow-origin",
                                         "--tls-cert", "--tls-key", "--no-net", "--steps", "--room", "--nats",
                                         "--relay", "--nats-creds", "default" };
    for (size_t i = 0; i < sizeof flags / sizeof flags[0]; i++)
        if (!strstr(out, flags[i])) fail_msg("--help does not mention %s", flags[i]);
    static const char *const bad[][4] = {
        { "--strands", "0", NULL }, { "--strands", "12x", NULL }, { "--bogus", NULL, NULL }, { "--port", "70000", NULL },
        { "--port", NULL, NULL },   { "--backend", "gpu", NULL }, { "--max-error", "1", NULL }, { "--rate", "nan", NULL },
        { "--web", "/nonexistent-dir", NULL }, { "--no-net=1", NULL, NULL }, { "--steps", "-1", NULL },
        { "--ping-interval", "0", NULL }, { "--ping-interval", "65535", NULL }, { "--ping-timeout", "65536", NULL },
        { "--ping-timeout", "20", NULL }, { "--ping-timeout=5", "--ping-interval", "5" }, { "--ping-timeout", "x", NULL },
        { "--max-clients", "0", NULL }, { "--max-clients", "5000", NULL }, { "--token-file", "/nonexistent/t", NULL },
        { "--allow-origin", "good.example", NULL }, { "--tls-cert", "/tmp/c.pem", NULL },
        { "--room", "a.b", NULL }, { "--room", "", NULL }, { "--nats", "http://127.0.0.1:4222", NULL },
        { "--relay", NULL, NULL }, { "--nats-creds", "/nonexistent/c.creds", NULL },
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        int rc = run_capture(cfg->exe, bad[i], out, sizeof out);
        char name[32];
        snprintf(name, sizeof name, "%.*s", (int)strcspn(bad[i][0], "="), bad[i][0]);
        if (rc != 2 || !strstr(out, name)) fail_msg("%s %s: exit %d, said: %s", bad[i][0], bad[i][1] ? bad[i][1] : "", rc, out);
    }
    /* beyond loopback without a token: refused at start-up unless told --insecure-open */
    const char *open_wide[] = { "--listen", "0.0.0.0", "--port", "0", "--steps", "1", NULL };
    int rc0 = run_capture(cfg->exe, open_wide, out, sizeof out);
    if (rc0 != 2 || !strstr(out, "--token-file")) fail_msg("--listen 0.0.0.0 without a token: exit %d, said: %s", rc0, out);
    /* an edge relay beyond loopback: only with --insecure-open (the token is the nodes') */
    const char *relay_wide[] = { "--relay", "--nats", "nats://127.0.0.1:1", "--listen", "0.0.0.0", NULL };
    rc0 = run_capture(cfg->exe, relay_wide, out, sizeof out);
    if (rc0 != 2 || !strstr(out, "--insecure-open")) fail_msg("--relay --listen 0.0.0.0: exit %d, said: %s", rc0, out);
    const char *insecure[] = { "--listen", "0.0.0.0", "--port", "0", "--steps", "2", "--insecure-open", "--backend", "cpu",
                               "--strands", "16", "--verts", "4", NULL };
    assert_int_equal(run_capture(cfg->exe, insecure, out, sizeof out), 0);
    /* a token file whose token is too short, or holds spaces */
    char tdir[64], tfile[96];
    snprintf(tdir, sizeof tdir, "/tmp/strandcast-token-XXXXXX");
    assert_non_null(mkdtemp(tdir));
    snprintf(tfile, sizeof tfile, "%s/t", tdir);
    static const char *const weak[] = { "short\n", "sixteen bytes ok but spaced\n" };
    for (int i = 0; i < 2; i++) {
        write_file(tfile, weak[i], strlen(weak[i]));
        const char *tok[] = { "--token-file", tfile, "--no-net", NULL };
        int rct = run_capture(cfg->exe, tok, out, sizeof out);
        if (rct != 2 || !strstr(out, "token")) fail_msg("weak token %d: exit %d, said: %s", i, rct, out);
    }
    unlink(tfile);
    rmdir(tdir);
    /* a NATS credentials file that is missing, a folder, or not one (no JWT, no seed): refused at
     * start-up with the reason, before any connection */
    char cdir[64], garbage[96], jwt_only[96];
    snprintf(cdir, sizeof cdir, "/tmp/strandcast-creds-XXXXXX");
    assert_non_null(mkdtemp(cdir));
    snprintf(garbage, sizeof garbage, "%s/garbage.creds", cdir);
    snprintf(jwt_only, sizeof jwt_only, "%s/jwt-only.creds", cdir);
    write_file(garbage, "not a credentials file\n", 23);
    static const char jwt[] = "-----BEGIN NATS USER JWT-----\neyJ0eXAiOiJKV1QifQ.e30.c2ln\n------END NATS USER JWT------\n";
    write_file(jwt_only, jwt, strlen(jwt));
    const char *const creds_bad[][2] = { { "/nonexistent/c.creds", "No such file" }, { cdir, "Is a directory" },
                                         { garbage, "no user JWT" }, { jwt_only, "no NKey user seed" } };
    for (size_t i = 0; i < sizeof creds_bad / sizeof creds_bad[0]; i++) {
        const char *args[] = { "--nats", "nats://127.0.0.1:1", "--nats-creds", creds_bad[i][0], NULL };
        int rcc = run_capture(cfg->exe, args, out, sizeof out);
        if (rcc != 2 || !strstr(out, "--nats-creds") || !strstr(out, creds_bad[i][1]))
            fail_msg("--nats-creds %s: exit %d, said: %s", creds_bad[i][0], rcc, out);
    }
    unlink(garbage);
    unlink(jwt_only);
    rmdir(cdir);
    const char *missing[] = { "--no-net", "--groom", "/nonexistent/x.tfx", NULL };
    assert_int_equal(run_capture(cfg->exe, missing, out, sizeof out), 1);
    assert_non_null(strstr(out, "x.tfx"));
    /* a groom file over the vertex limit once resampled: refused at start-up as by set_groom */
    char dir[64], big[96];
    snprintf(dir, sizeof dir, "/tmp/strandcast-big-XXXXXX");
    assert_non_null(mkdtemp(dir));
    snprintf(big, sizeof big, "%s/big.hair", dir);
    write_hair(big, 70000, 2, 0.0f);
    const char *too_big[] = { "--no-net", "--groom", big, "--verts", "32", NULL };
    int rc = run_capture(cfg->exe, too_big, out, sizeof out);
    unlink(big);
    rmdir(dir);
    if (rc != 1 || !strstr(out, "2240000")) fail_msg("a 70,000 x 32 groom file: exit %d, said: %s", rc, out);
    /* a collision mesh that cannot be read or is malformed: exit 1 with the loader's message */
    const char *no_mesh[] = { "--no-net", "--collider", "/nonexistent/body.obj", NULL };
    rc = run_capture(cfg->exe, no_mesh, out, sizeof out);
    if (rc != 1 || !strstr(out, "body.obj")) fail_msg("a missing --collider: exit %d, said: %s", rc, out);
    char open_mesh[96];
    snprintf(dir, sizeof dir, "/tmp/strandcast-mesh-XXXXXX");
    assert_non_null(mkdtemp(dir));
    snprintf(open_mesh, sizeof open_mesh, "%s/open.obj", dir);
    write_file(open_mesh, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 32);
    const char *bad_mesh[] = { "--no-net", "--collider", open_mesh, NULL };
    rc = run_capture(cfg->exe, bad_mesh, out, sizeof out);
    unlink(open_mesh);
    rmdir(dir);
    if (rc != 1 || !strstr(out, "open.obj")) fail_msg("an open --collider mesh: exit %d, said: %s", rc, out);
    const char *empty_mesh[] = { "--collider=", NULL };
    assert_int_equal(run_capture(cfg->exe, empty_mesh, out, sizeof out), 2);
    /* a start-up groom over the active solver's budget: exit 1 naming the solver */
    const char *slow[] = { "--no-net", "--backend", "cpu", "--solver", "pbd", "--strands", "4096", "--verts", "32",
                           "--min-step-rate", "400", NULL };
    rc = run_capture(cfg->exe, slow, out, sizeof out);
    if (rc != 1 || !strstr(out, "with the pbd solver")) fail_msg("4,096 x 32 under pbd at 400 steps/s: exit %d, said: %s", rc, out);
    const char *run[] = { "--no-net", "--steps", "5", "--backend", "cpu", "--strands", "16", "--verts", "4",
                          "--threads", "1", NULL };
    assert_int_equal(run_capture(cfg->exe, run, out, sizeof out), 0);
    assert_non_null(strstr(out, "stopped after 5 steps"));
}

/* Counts the occurrences of needle in hay. */
static int count_of(const char *hay, const char *needle)
{
    int n = 0;
    for (const char *p = strstr(hay, needle); p; p = strstr(p + 1, needle)) n++;
    return n;
}

/* strandcastc, the command-line client (built beside strandcastd): it subscribes, waits for the
 * reply, decodes frames with the C decoder, prints them and records them as SCFR; bad flags
 * exit 2 and a port nobody listens on exits 1. */
void test_cli_client(void **state)
{
    fixture *fx = *state;
    char exe[1024], port[16], rec[160];
    snprintf(exe, sizeof exe, "%s", fx->cfg->exe);
    char *slash = strrchr(exe, '/');
    snprintf(slash ? slash + 1 : exe, sizeof exe - (size_t)(slash ? slash + 1 - exe : 0), "strandcastc");
    snprintf(port, sizeof port, "%d", fx->d.port);
    snprintf(rec, sizeof rec, "%s/rec.scfr", fx->dir);
    const char *args[] = { "--port", port, "--frames", "12", "--json", "--out", rec, "--send",
                           "{\"type\":\"subscribe\",\"stride\":4,\"max_error\":0.001,\"id\":\"s\"}", NULL };
    static char out[1 << 17];
    int rc = run_capture(exe, args, out, sizeof out);
    if (rc != 0) fail_msg("strandcastc exited %d:\n%s", rc, out);
    if (!strstr(out, "{\"cli\":\"hello\",\"server\":\"strandcastd\"") || !strstr(out, "\"strands\":128,\"verts\":8,"))
        fail_msg("no hello summary:\n%s", out);
    const char *sub = strstr(out, "{\"type\":\"subscribed\",\"id\":\"s\"");
    const char *first = strstr(out, "{\"cli\":\"frame\",\"frame\":0,");
    if (!sub || !first || first < sub) fail_msg("frames shown before the subscribe's reply:\n%s", out);
    assert_true(strstr(first, "\"keyframe\":true") < strchr(first, '\n')); /* the new stream starts with a keyframe */
    if (count_of(out, "{\"cli\":\"frame\"") != 12 || count_of(out, "\"strands\":32,\"strands_total\":128,\"verts\":8,\"stride\":4,") != 12)
        fail_msg("want 12 frames of every 4th strand:\n%s", out);
    /* each frame line reports its step and the head its header carries (at rest: the identity) */
    if (count_of(out, "\"sim_step\":") != 12 ||
        count_of(out, "\"head\":{\"position\":[0,0,0],\"orientation\":[0,0,0,1]},") != 12)
        fail_msg("want sim_step and the head in every frame line:\n%s", out);
    if (!strstr(out, "\"frames\":12,") || !strstr(out, "\"recorded\":12,") || !strstr(out, "\"ok\":true}"))
        fail_msg("summary:\n%s", out);
    /* the recording: SCFR header, then 12 frames of 32 x 8 finite positions near the head, then
       "SCFM" and each frame's step (increasing) and head (the identity: at rest) */
    size_t len;
    FILE *fp = fopen(rec, "rb");
    assert_non_null(fp);
    static float xyz[4 + 12 * 32 * 8 * 3 + 1 + 12 * 9 + 1];
    len = fread(xyz, 1, sizeof xyz, fp);
    fclose(fp);
    const size_t npos = 12 * 32 * 8 * 3;
    assert_int_equal(len, 16 + npos * sizeof(float) + 4 + 12 * 36);
    uint32_t h[4];
    memcpy(h, xyz, sizeof h);
    assert_memory_equal(h, "SCFR", 4);
    assert_true(h[1] == 32 && h[2] == 8 && h[3] == 12);
    for (size_t i = 4; i < 4 + npos; i++)
        if (!(fabsf(xyz[i]) < 1.0f)) fail_msg("recorded coordinate %zu is %g", i - 4, (double)xyz[i]);
    const uint8_t *trailer = (const uint8_t *)(xyz + 4 + npos);
    assert_memory_equal(trailer, "SCFM", 4);
    uint64_t prev = 0;
    for (int f = 0; f < 12; f++) {
        const uint8_t *m = trailer + 4 + 36 * f;
        uint64_t step;
        float head[7];
        memcpy(&step, m, 8);
        memcpy(head, m + 8, sizeof head);
        if (f > 0 && step <= prev) fail_msg("recorded frame %d has step %llu after %llu", f, (unsigned long long)step,
                                            (unsigned long long)prev);
        prev = step;
        const float identity[7] = { 0, 0, 0, 0, 0, 0, 1 };
        assert_memory_equal(head, identity, sizeof head);
    }

    const char *bad[] = { "--port", "0", NULL };
    assert_int_equal(run_capture(exe, bad, out, sizeof out), 2);
    const char *bad2[] = { "--frames", "-1", NULL };
    assert_int_equal(run_capture(exe, bad2, out, sizeof out), 2);
    const char *nobody[] = { "--port", "1", "--frames", "1", NULL };
    rc = run_capture(exe, nobody, out, sizeof out);
    if (rc != 1 || !strstr(out, "cannot connect")) fail_msg("no daemon: exit %d:\n%s", rc, out);
}
