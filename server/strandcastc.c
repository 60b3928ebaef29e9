/* strandcastc: a command-line client of strandcastd: sends control messages, decodes the strand
 * frames with the C decoder, prints them and records the positions (SCFR, as strandbench reads)
 * with each frame's step and head transform after them; `run` and `check` hand over to
 * server/scen/ (scripted scenarios, frame invariants). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "codec/codec.h"
#include "core/cli.h"
#include "core/core.h"
#include "net/net.h"
#include "proto/proto.h"
#include "scen/scen.h"
#include "wsc/wsc.h"

#define PROG "strandcastc"
#define CLI_MAX_SEND 32
#define CLI_CONNECT_MS 5000
#define CLI_META_BYTES 36u /* a recorded frame's u64 sim_step, float32 head position x3, orientation x4 */

static const char *const USAGE =
    "usage: strandcastc [--host H] [--port N] [--room NAME] [--send JSON]... [--frames N] [--seconds S]\n"
    "                   [--out FILE] [--json]\n"
    "       strandcastc run [--host H] [--port N] [--room NAME] [--json] SCRIPT.json   (a scripted scenario: run --help)\n"
    "       strandcastc check [--host H] [--port N] [--room NAME] [flags]             (frame invariants: check --help)\n"
    "       strandcastc --compare A.scfr B.scfr [--json]                (largest position difference per frame)\n"
    "Connects to a running strandcastd (subprotocol " PROTO_SUBPROTOCOL "), shows its hello, sends each\n"
    "--send message in order (replies and broadcasts are printed as they come; stats are not),\n"
    "then decodes the strand frames with the C decoder and prints one line per frame. Frames are\n"
    "counted, printed and recorded once every --send message with an \"id\" has its reply (give\n"
    "one an id to see its effect, e.g. a subscribe, in every frame shown).\n"
    "  --host H      address of the daemon (default 127.0.0.1)\n"
    "  --port N      its port (default 7681)\n"
    "  --room NAME   the room to join, at ws://HOST:PORT/rooms/NAME (a daemon started with --room, or\n"
    "                an edge relay); default: the room \"default\" at /\n"
    "  --send JSON   a control message, e.g. '{\"type\":\"subscribe\",\"stride\":4}' (up to 32)\n"
    "  --frames N    stop after N decoded frames (default 10; 0 = until --seconds)\n"
    "  --seconds S   stop after S seconds in any case, 0.001..86400 (default 10)\n"
    "  --out FILE    write the decoded positions as SCFR: \"SCFR\", u32 strands, u32 vertices,\n"
    "                u32 frames, then the frames' float32 xyz, strand-major (strandbench codec\n"
    "                --frames reads it), then \"SCFM\" and per frame its header's u64 sim_step and\n"
    "                head transform (float32 position xyz, orientation xyzw), in the host's byte\n"
    "                order as the rest; frames of another shape (a groom change) are not written\n"
    "  --json        one JSON object per line: {\"cli\":\"hello\"|\"frame\"|\"summary\",...}, and the\n"
    "                server's text messages as they are\n"
    "Exit status: 0 when the frames asked for were decoded (or, with --frames 0, at least one),\n"
    "1 when the connection fails or closes early, a frame does not decode or the file cannot be\n"
    "written, 2 for bad flags.\n";

typedef struct cli_desc {
    const char *host, *out;
    int port;
    char path[PROTO_ROOM_PATH_MAX]; /* the WebSocket request path: "/" or /rooms/NAME */
    const char *send[CLI_MAX_SEND];
    int nsend;
    unsigned long frames;
    double seconds;
    bool json;
} cli_desc;

/* What the client has decoded and written so far. */
typedef struct cli {
    cli_desc d;
    codec_decoder dec;
    float *xyz;
    size_t cap;
    FILE *fp;
    uint32_t rec_strands, rec_verts, rec_frames;
    uint8_t *meta;       /* per recorded frame: CLI_META_BYTES of its step and head (the trailer) */
    size_t meta_cap;
    proto_id pending[CLI_MAX_SEND]; /* ids of --send messages not answered yet */
    int npending;
    bool sent;           /* the hello is shown and the --send messages are out: frames count */
    unsigned long frames, keys, bad, other_shape, early;
    unsigned long long bytes, vertices;
    bool write_failed;
    char error[CORE_ERR_MAX + 64];
} cli;

enum { OPT_HOST = 256, OPT_PORT, OPT_ROOM, OPT_SEND, OPT_FRAMES, OPT_SECONDS, OPT_OUT, OPT_JSON };

static const struct option options[] = {
    { "host", required_argument, NULL, OPT_HOST },
    { "port", required_argument, NULL, OPT_PORT },
    { "room", required_argument, NULL, OPT_ROOM },
    { "send", required_argument, NULL, OPT_SEND },
    { "frames", required_argument, NULL, OPT_FRAMES },
    { "seconds", required_argument, NULL, OPT_SECONDS },
    { "out", required_argument, NULL, OPT_OUT },
    { "json", no_argument, NULL, OPT_JSON },
    { "help", no_argument, NULL, 'h' },
    { NULL, 0, NULL, 0 },
};

/* Returns 0 and fills d, or an exit status (--help prints and returns -1). */
static int parse_args(int argc, char **argv, cli_desc *d)
{
    memset(d, 0, sizeof *d);
    d->host = "127.0.0.1";
    d->port = NET_DEFAULT_PORT;
    strcpy(d->path, "/");
    d->frames = 10;
    d->seconds = 10.0;
    core_cli_begin();
    char flag[64];
    int opt, status;
    while ((opt = core_cli_next(PROG, argc, argv, options, flag, sizeof flag, &status)) > 0) {
        if (opt == 'h') {
            fputs(USAGE, stdout);
            return -1;
        }
        const char *v = optarg;
        unsigned long long u = 0;
        int rc = 0;
        switch (opt) {
        case OPT_HOST: d->host = v; break;
        case OPT_ROOM:
            if (!proto_room_path(v, d->path, sizeof d->path))
                return core_cli_bad(PROG, flag, v, "is not a room name: 1..64 letters, digits, '-' or '_'");
            break;
        case OPT_OUT: d->out = v; break;
        case OPT_JSON: d->json = true; break;
        case OPT_SEND:
            if (d->nsend == CLI_MAX_SEND) return core_cli_bad(PROG, flag, NULL, "given more than 32 times");
            if (strlen(v) > PROTO_MAX_MESSAGE) return core_cli_bad(PROG, flag, NULL, "message over 65536 bytes");
            d->send[d->nsend++] = v;
            break;
        case OPT_PORT:
            if (!(rc = core_cli_u64(PROG, flag, v, 1, 65535, &u))) d->port = (int)u;
            break;
        case OPT_FRAMES:
            if (!(rc = core_cli_u64(PROG, flag, v, 0, 100000000ull, &u))) d->frames = (unsigned long)u;
            break;
        case OPT_SECONDS:
            rc = core_cli_f64(PROG, flag, v, 0.001, 86400.0, &d->seconds);
            break;
        }
        if (rc) return rc;
    }
    return status;
}

/* Marks the recording failed with errno's reason (the first failure is kept). */
static void write_failed(cli *c)
{
    if (c->write_failed) return;
    c->write_failed = true;
    snprintf(c->error, sizeof c->error, "writing %s: %s", c->d.out, strerror(errno));
}

/* Appends one decoded frame to the SCFR file; the first frame fixes the shape. */
static void record(cli *c, const codec_frame_info *info)
{
    if (!c->fp || c->write_failed) return;
    if (c->rec_frames == 0) {
        c->rec_strands = info->nstrands_sent;
        c->rec_verts = info->nverts;
    } else if (info->nstrands_sent != c->rec_strands || info->nverts != c->rec_verts) {
        if (c->other_shape++ == 0)
            fprintf(stderr, "strandcastc: frame seq %llu has %u x %u vertices, the recording %u x %u: not written\n",
                    (unsigned long long)info->seq, info->nstrands_sent, info->nverts, c->rec_strands, c->rec_verts);
        return;
    }
    size_t n = 3u * (size_t)info->nstrands_sent * info->nverts, at = (size_t)c->rec_frames * CLI_META_BYTES;
    if (at + CLI_META_BYTES > c->meta_cap) {
        size_t cap = c->meta_cap ? 2u * c->meta_cap : 64u * CLI_META_BYTES;
        uint8_t *m = realloc(c->meta, cap);
        if (!m) {
            c->write_failed = true;
            snprintf(c->error, sizeof c->error, "out of memory for the recording's frame steps");
            return;
        }
        c->meta = m;
        c->meta_cap = cap;
    }
    if (fwrite(c->xyz, sizeof *c->xyz, n, c->fp) != n) {
        write_failed(c);
        return;
    }
    uint8_t *m = c->meta + at;
    memcpy(m, &info->sim.sim_step, 8);
    memcpy(m + 8, info->sim.head_pos, 12);
    memcpy(m + 20, info->sim.head_rot, 16);
    c->rec_frames++;
}

static void print_frame(const cli *c, const codec_frame_info *info, size_t len)
{
    size_t nv = (size_t)info->nstrands_sent * info->nverts;
    float lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (size_t i = 0; i < nv; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fminf(lo[k], c->xyz[3 * i + (size_t)k]);
            hi[k] = fmaxf(hi[k], c->xyz[3 * i + (size_t)k]);
        }
    const codec_sim_info *s = &info->sim;
    if (c->d.json) {
        printf("{\"cli\":\"frame\",\"frame\":%lu,\"seq\":%llu,\"keyframe\":%s,\"ref_seq\":%llu,\"bytes\":%zu,"
               "\"sim_time\":%.6f,\"sim_step\":%llu,\"head\":{\"position\":[%.9g,%.9g,%.9g],"
               "\"orientation\":[%.9g,%.9g,%.9g,%.9g]},\"strands\":%u,\"strands_total\":%u,\"verts\":%u,\"stride\":%u,"
               "\"max_error_m\":%g,\"bytes_per_vertex\":%.4f,\"bounds\":[%g,%g,%g,%g,%g,%g]}\n",
               c->frames, (unsigned long long)info->seq, info->keyframe ? "true" : "false",
               (unsigned long long)info->ref_seq, len, s->sim_time, (unsigned long long)s->sim_step,
               (double)s->head_pos[0], (double)s->head_pos[1], (double)s->head_pos[2], (double)s->head_rot[0],
               (double)s->head_rot[1], (double)s->head_rot[2], (double)s->head_rot[3], info->nstrands_sent,
               info->nstrands_total, info->nverts, info->stride, (double)info->max_error_m, (double)len / (double)nv,
               lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    } else {
        printf("%6lu %10llu %-5s %10llu %9zu %10.4f %8llu %7u x %-4u %8.4f  [%.3f %.3f %.3f]..[%.3f %.3f %.3f]  "
               "[%.3f %.3f %.3f] [%.3f %.3f %.3f %.3f]\n",
               c->frames, (unsigned long long)info->seq, info->keyframe ? "key" : "delta",
               (unsigned long long)info->ref_seq, len, s->sim_time, (unsigned long long)s->sim_step, info->nstrands_sent,
               info->nverts, (double)len / (double)nv, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2], (double)s->head_pos[0],
               (double)s->head_pos[1], (double)s->head_pos[2], (double)s->head_rot[0], (double)s->head_rot[1],
               (double)s->head_rot[2], (double)s->head_rot[3]);
    }
}

static void on_frame(wsc_conn *conn, const uint8_t *data, size_t len, void *user)
{
    (void)conn;
    cli *c = user;
    if (c->d.frames && c->frames >= c->d.frames) return;
    codec_frame_info info;
    core_err err;
    if (codec_peek_header(data, len, &info, &err) == CORE_OK) {
        size_t need = 3u * (size_t)info.nstrands_sent * info.nverts;
        if (need > c->cap) {
            float *x = realloc(c->xyz, need * sizeof *x);
            if (!x) {
                core_fail(&err, CORE_ENOMEM, "out of memory for %zu positions", need);
                goto bad;
            }
            c->xyz = x;
            c->cap = need;
        }
        if (codec_decode(&c->dec, data, len, c->xyz, c->cap, &info, &err) == CORE_OK) {
            if (!c->sent || c->npending) { /* decoded (the decoder keeps its keyframe), not shown */
                c->early++;
                return;
            }
            print_frame(c, &info, len);
            record(c, &info);
            c->frames++;
            c->keys += info.keyframe;
            c->bytes += len;
            c->vertices += (size_t)info.nstrands_sent * info.nverts;
            return;
        }
    }
bad:
    c->bad++;
    snprintf(c->error, sizeof c->error, "frame %lu does not decode: %s", c->frames, err.msg);
}

/* Prints the server's text messages from *next on (stats are left out) and ticks off the
 * --send messages they answer. */
static void print_texts(cli *c, wsc_conn *conn, size_t *next)
{
    size_t n;
    char *const *t = wsc_texts(conn, &n);
    for (; *next < n; (*next)++) {
        char type[32];
        proto_id id;
        proto_read_envelope(t[*next], strlen(t[*next]), type, sizeof type, &id);
        if (strcmp(type, "stats") == 0 || strcmp(type, "hello") == 0) continue;
        printf(c->d.json ? "%s\n" : "< %s\n", t[*next]);
        for (int i = 0; i < c->npending && id.kind != PROTO_ID_NONE; i++)
            if (proto_id_equal(&c->pending[i], &id)) {
                c->pending[i] = c->pending[--c->npending];
                break;
            }
    }
}

/* Prints s as a JSON string (quotes, backslashes and control characters escaped). */
static void put_json_string(const char *s)
{
    putchar('"');
    for (; *s; s++) {
        unsigned char ch = (unsigned char)*s;
        if (ch == '"' || ch == '\\') printf("\\%c", ch);
        else if (ch < 0x20) printf("\\u%04x", ch);
        else putchar(ch);
    }
    putchar('"');
}

static void print_hello(const cli *c, const proto_hello_info *h)
{
    if (c->d.json) {
        printf("{\"cli\":\"hello\",\"server\":");
        put_json_string(h->server);
        printf(",\"version\":");
        put_json_string(h->version);
        printf(",\"source\":");
        put_json_string(h->source);
        printf(",\"protocol\":%g,\"client\":%g,\"strands\":%g,\"verts\":%g,\"stride\":%g,\"max_error\":%g,"
               "\"rate\":%g,\"frame_rate\":%g}\n",
               h->protocol, h->client, h->strands, h->verts, h->stride, h->max_error, h->rate, h->frame_rate);
        return;
    }
    printf("strandcastc: ws://%s:%d/ %s: %s %s (protocol %g), client %g; groom %s: %g x %g; stream stride %g, "
           "%g mm, %g of %g frames/s\n",
           c->d.host, c->d.port, PROTO_SUBPROTOCOL, h->server, h->version, h->protocol, h->client, h->source,
           h->strands, h->verts, h->stride, h->max_error * 1e3, h->frame_rate, h->rate);
    printf("%6s %10s %-5s %10s %9s %10s %8s %14s %8s  %-39s  %s\n", "frame", "seq", "kind", "ref_seq", "bytes", "sim_time",
           "sim_step", "strands x verts", "B/vertex", "bounds (m)", "head position (m), orientation [x y z w]");
}

typedef struct until_arg {
    cli *c;
    wsc_conn *conn;
} until_arg;

static bool finished(void *arg)
{
    until_arg *u = arg;
    return !wsc_is_open(u->conn) || u->c->bad || u->c->write_failed ||
           (u->c->d.frames && u->c->frames >= u->c->d.frames);
}

/* Appends the frames' steps and heads, rewrites the SCFR header with the frame count and closes
 * the file. */
static void close_recording(cli *c)
{
    if (!c->fp) return;
    const size_t meta = (size_t)c->rec_frames * CLI_META_BYTES;
    if (!c->write_failed && (fwrite("SCFM", 1, 4, c->fp) != 4 || (meta && fwrite(c->meta, 1, meta, c->fp) != meta)))
        write_failed(c);
    uint32_t h[3] = { c->rec_strands, c->rec_verts, c->rec_frames };
    if (!c->write_failed && (fseek(c->fp, 4, SEEK_SET) != 0 || fwrite(h, sizeof h[0], 3, c->fp) != 3)) write_failed(c);
    if (fclose(c->fp) != 0) write_failed(c);
    c->fp = NULL;
}

static int run(cli *c)
{
    if (c->d.out) {
        c->fp = fopen(c->d.out, "wb");
        static const char magic[16] = "SCFR";
        if (!c->fp || fwrite(magic, 1, sizeof magic, c->fp) != sizeof magic) {
            fprintf(stderr, "strandcastc: cannot write %s: %s\n", c->d.out, strerror(errno));
            if (c->fp) fclose(c->fp);
            return 1;
        }
    }
    wsc *w = wsc_new();
    wsc_conn *conn = w ? wsc_connect_host(w, c->d.host, c->d.port, c->d.path, PROTO_SUBPROTOCOL, on_frame, c) : NULL;
    int rc = 1;
    if (!conn || !wsc_wait_open(w, conn, CLI_CONNECT_MS)) {
        fprintf(stderr, "strandcastc: cannot connect to ws://%s:%d%s with subprotocol %s\n", c->d.host, c->d.port,
                c->d.path, PROTO_SUBPROTOCOL);
        goto done;
    }
    const char *hello = wsc_next_of_type(w, conn, "hello", CLI_CONNECT_MS);
    proto_hello_info h;
    core_err err;
    if (!hello || proto_read_hello(hello, strlen(hello), &h, &err) != CORE_OK) {
        const char *why = hello ? err.msg : wsc_last_text(conn); /* a refusal the server sent */
        fprintf(stderr, "strandcastc: no hello from the server%s%.300s\n", *why ? ": " : "", why);
        goto done;
    }
    print_hello(c, &h);
    if (h.protocol != PROTO_VERSION)
        fprintf(stderr, "strandcastc: the server speaks protocol %g, this client %d\n", h.protocol, PROTO_VERSION);
    for (int i = 0; i < c->d.nsend; i++) {
        char type[32];
        proto_id id;
        if (proto_read_envelope(c->d.send[i], strlen(c->d.send[i]), type, sizeof type, &id) == CORE_OK &&
            id.kind != PROTO_ID_NONE)
            c->pending[c->npending++] = id;
        wsc_send_text(conn, c->d.send[i]);
        if (!c->d.json) printf("> %s\n", c->d.send[i]);
    }
    c->sent = true; /* frames that came with the hello are not shown before it */
    size_t next = 0;
    unsigned long long t0 = core_now_ns(), limit = (unsigned long long)(c->d.seconds * 1e9);
    until_arg u = { c, conn };
    while (!finished(&u) && core_now_ns() - t0 < limit) {
        wsc_until(w, finished, &u, 50);
        print_texts(c, conn, &next);
    }
    print_texts(c, conn, &next);
    double secs = (double)(core_now_ns() - t0) / 1e9;
    bool enough = c->d.frames ? c->frames >= c->d.frames : c->frames > 0;
    close_recording(c);
    if (c->bad || c->write_failed) fprintf(stderr, "strandcastc: %s\n", c->error);
    else if (!enough && !wsc_is_open(conn))
        fprintf(stderr, "strandcastc: the server closed the connection (%d %s) after %lu frames\n", wsc_close_code(conn),
                wsc_close_reason(conn), c->frames);
    else if (!enough && c->npending)
        fprintf(stderr, "strandcastc: %d --send message(s) with an id got no reply in %.1f s\n", c->npending, secs);
    else if (!enough)
        fprintf(stderr, "strandcastc: %lu of %lu frames in %.1f s\n", c->frames, c->d.frames, secs);
    rc = enough && !c->bad && !c->write_failed ? 0 : 1;
    double bpv = c->vertices ? (double)c->bytes / (double)c->vertices : 0.0;
    if (c->d.json)
        printf("{\"cli\":\"summary\",\"frames\":%lu,\"keyframes\":%lu,\"bad\":%lu,\"bytes\":%llu,\"bytes_per_vertex\":%.4f,"
               "\"seconds\":%.3f,\"recorded\":%u,\"other_shape\":%lu,\"before_replies\":%lu,\"ok\":%s}\n",
               c->frames, c->keys, c->bad, c->bytes, bpv, secs, c->rec_frames, c->other_shape, c->early,
               rc ? "false" : "true");
    else
        printf("strandcastc: %lu frames (%lu keyframes) in %.2f s, %.4f bytes/vertex%s%s\n", c->frames, c->keys, secs,
               bpv, c->d.out ? "; recorded to " : "", c->d.out ? c->d.out : "");
done:
    close_recording(c);
    wsc_free(w);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "run") == 0) return scen_cli_run(argc - 1, argv + 1);
    if (argc > 1 && strcmp(argv[1], "check") == 0) return scen_cli_check(argc - 1, argv + 1);
    if (argc > 1 && strcmp(argv[1], "--compare") == 0) return scen_cli_compare(argc - 1, argv + 1);
    cli c;
    memset(&c, 0, sizeof c);
    int rc = parse_args(argc, argv, &c.d);
    if (rc) return rc < 0 ? 0 : rc;
    codec_decoder_init(&c.dec);
    rc = run(&c);
    codec_decoder_free(&c.dec);
    free(c.xyz);
    free(c.meta);
    return rc;
}
