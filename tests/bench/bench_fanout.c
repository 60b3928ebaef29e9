/* strandbench fanout: N loopback WebSocket clients on the real strandcastd; sim rate, frames per
 * client and server CPU. */
#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include "bench.h"
#include "core/cli.h"
#include "fanout_rx.h"
#include "proto/proto.h"
#include "support/daemon.h"
#include "support/natsd.h"
#include "wsc/wsc.h"

#define MAX_CASES 16
#define MAX_EDGES 8

typedef struct fanout_opts {
    int clients[MAX_CASES];
    int ncases;
    double seconds;
    double warmup; /* seconds of streaming before the measurement (the hair settles from its rest pose) */
    double max_rate;
    double server_rate; /* the daemon's --rate; 0 = its default (60) */
    int strands, verts;
    const char *daemon;
    const char *params; /* a set_params "values" object sent before measuring, or NULL */
    const char *animate; /* a head-motion preset started before the warm-up, or NULL (head at rest) */
    int edges;           /* 0: clients on the daemon itself; else a simulation node and this many edge relays over
                          * nats-server, the clients spread over the edges (the case being run) */
    int edge_list[MAX_EDGES]; /* --edges: the edge counts to run, in order */
    int nedge_list;           /* 0: one run with the clients on the daemon */
    bool json;
} fanout_opts;

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
}

/* CPU seconds (user + system) of a process from /proc/PID/stat. */
static double proc_cpu_s(pid_t pid)
{
    char path[64], buf[1024];
    snprintf(path, sizeof path, "/proc/%d/stat", (int)pid);
    FILE *f = fopen(path, "r");
    if (!f) return -1;
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = '\0';
    const char *p = strrchr(buf, ')');
    if (!p) return -1;
    unsigned long utime = 0, stime = 0;
    /* fields after the command: state(3) ... utime(14) stime(15) */
    if (sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %lu %lu", &utime, &stime) != 2) return -1;
    return (double)(utime + stime) / (double)sysconf(_SC_CLK_TCK);
}

/* CPU seconds of the process's threads named comm (e.g. "sc-net", set by strandcastd). */
static double thread_cpu_s(pid_t pid, const char *comm)
{
    char dir[64];
    snprintf(dir, sizeof dir, "/proc/%d/task", (int)pid);
    DIR *d = opendir(dir);
    if (!d) return -1;
    double total = 0;
    struct dirent *de;
    while ((de = readdir(d))) {
        if (de->d_name[0] == '.') continue;
        char path[384], name[64] = "";
        snprintf(path, sizeof path, "%s/%s/comm", dir, de->d_name);
        FILE *f = fopen(path, "r");
        if (!f) continue;
        if (fgets(name, sizeof name, f)) name[strcspn(name, "\n")] = '\0';
        fclose(f);
        if (strcmp(name, comm) != 0) continue;
        snprintf(path, sizeof path, "%s/%s/stat", dir, de->d_name);
        f = fopen(path, "r");
        if (!f) continue;
        char buf[1024];
        size_t n = fread(buf, 1, sizeof buf - 1, f);
        fclose(f);
        buf[n] = '\0';
        const char *p = strrchr(buf, ')');
        unsigned long ut = 0, st = 0;
        if (p && sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %lu %lu", &ut, &st) == 2)
            total += (double)(ut + st) / (double)sysconf(_SC_CLK_TCK);
    }
    closedir(d);
    return total;
}

static double self_cpu_s(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_utime.tv_sec + ru.ru_utime.tv_usec / 1e6 + (double)ru.ru_stime.tv_sec + ru.ru_stime.tv_usec / 1e6;
}

/* A counter from /metrics ("name value" line); -1 when unavailable. */
static double metric(int port, const char *name)
{
    http_reply r;
    if (http_get(port, "/metrics", &r) != 0) return -1;
    char pat[128];
    snprintf(pat, sizeof pat, "\n%s ", name);
    const char *p = r.body ? strstr(r.body, pat) : NULL;
    double v = p ? atof(p + strlen(pat)) : -1;
    http_reply_free(&r);
    return v;
}

#define PROG "strandbench fanout"

static const char *const FANOUT_USAGE =
    "usage: strandbench fanout [--clients 1,10,100] [--seconds S] [--warmup S] [--rate HZ] [--server-rate HZ]\n"
    "                          [--strands N] [--verts N] [--edges 1,2] [--daemon PATH] [--json]\n"
    "Starts strandcastd (default scene unless --strands/--verts) on a free loopback port, connects N\n"
    "WebSocket clients from one thread (lean raw-socket receivers on one epoll loop; each subscribes\n"
    "with max_rate HZ, default 30; 0 = every frame), streams for the warm-up (default 6 s: the hair\n"
    "settles from its rest pose, the costliest seconds of a run) and then measures over S seconds\n"
    "(default 5): sim steps/s, frames per client per second, server CPU\n"
    "(fraction of one core, /proc; the net thread's share and its CPU per frame delivered to one client\n"
    "are robust to other load). A 0-client run first gives the sim's baseline on this machine.\n"
    "--server-rate passes --rate to the daemon (frames it publishes per second; default 60).\n"
    "--params '{\"sph\":false}' sends set_params first (e.g. to separate solver cost from fan-out cost).\n"
    "--animate PRESET starts a head-motion preset first (nod, shake, circle, headbang, sway; default: the\n"
    "head stays at rest, and once the hair has settled the delta frames are small).\n"
    "--edges 1,2 (counts 0..8; 0 = no NATS): edge mode, run for each count in turn (a fresh baseline each):\n"
    "nats-server, the daemon as a simulation node (--nats) and E edge relays (--relay) on free loopback\n"
    "ports, the clients spread evenly over the edges; adds the edges' CPU per\n"
    "frame delivered to one client, and the node's CPU and NATS publishes (once per stream frame, which must\n"
    "not grow with edges or clients).";

enum { OPT_CLIENTS = 256, OPT_SECONDS, OPT_WARMUP, OPT_RATE, OPT_SERVER_RATE, OPT_STRANDS, OPT_VERTS, OPT_ANIMATE,
       OPT_PARAMS, OPT_DAEMON, OPT_JSON, OPT_EDGES };

static const struct option fanout_options[] = {
    { "clients", required_argument, NULL, OPT_CLIENTS }, { "seconds", required_argument, NULL, OPT_SECONDS },
    { "warmup", required_argument, NULL, OPT_WARMUP },   { "rate", required_argument, NULL, OPT_RATE },
    { "server-rate", required_argument, NULL, OPT_SERVER_RATE },
    { "strands", required_argument, NULL, OPT_STRANDS }, { "verts", required_argument, NULL, OPT_VERTS },
    { "animate", required_argument, NULL, OPT_ANIMATE }, { "params", required_argument, NULL, OPT_PARAMS },
    { "daemon", required_argument, NULL, OPT_DAEMON },   { "json", no_argument, NULL, OPT_JSON },
    { "edges", required_argument, NULL, OPT_EDGES },
    { "help", no_argument, NULL, 'h' },                  { NULL, 0, NULL, 0 },
};

/* --clients: a comma-separated list of counts in [1, 1000]. */
static int parse_clients(const char *flag, const char *v, fanout_opts *o)
{
    o->ncases = 0;
    const char *p = v;
    while (*p) {
        char item[16];
        size_t n = strcspn(p, ",");
        unsigned long long u;
        snprintf(item, sizeof item, "%.*s", (int)(n < sizeof item ? n : sizeof item - 1), p);
        if (o->ncases == MAX_CASES || n >= sizeof item)
            return core_cli_bad(PROG, flag, v, "expected at most 16 counts, comma-separated");
        int rc = core_cli_u64(PROG, flag, item, 1, 1000, &u);
        if (rc) return rc;
        o->clients[o->ncases++] = (int)u;
        p += n + (p[n] == ',');
    }
    return o->ncases ? 0 : core_cli_bad(PROG, flag, v, "expected a count");
}

/* 0 and fills o; 1 after --help; or the bad-flag exit status. */
static int parse_opts(int argc, char **argv, fanout_opts *o)
{
    o->ncases = 0;
    o->seconds = 5;
    o->warmup = 6;
    o->max_rate = 30;
    core_cli_begin();
    char flag[32];
    int opt, status;
    while ((opt = core_cli_next(PROG, argc, argv, fanout_options, flag, sizeof flag, &status)) > 0) {
        if (opt == 'h') {
            puts(FANOUT_USAGE);
            return 1;
        }
        const char *v = optarg;
        unsigned long long u = 0;
        int rc = 0;
        switch (opt) {
        case OPT_JSON: o->json = true; break;
        case OPT_CLIENTS: rc = parse_clients(flag, v, o); break;
        case OPT_SECONDS: rc = core_cli_f64(PROG, flag, v, 1, 600, &o->seconds); break;
        case OPT_WARMUP: rc = core_cli_f64(PROG, flag, v, 0, 600, &o->warmup); break;
        case OPT_RATE: rc = core_cli_f64(PROG, flag, v, 0, 240, &o->max_rate); break;
        case OPT_SERVER_RATE: rc = core_cli_f64(PROG, flag, v, 1, 1000, &o->server_rate); break;
        case OPT_STRANDS:
            if (!(rc = core_cli_u64(PROG, flag, v, 1, PROTO_MAX_STRANDS, &u))) o->strands = (int)u;
            break;
        case OPT_VERTS:
            if (!(rc = core_cli_u64(PROG, flag, v, 2, PROTO_MAX_VERTS, &u))) o->verts = (int)u;
            break;
        case OPT_ANIMATE:
            if (strlen(v) > 32 || strspn(v, "abcdefghijklmnopqrstuvwxyz") != strlen(v))
                return core_cli_bad(PROG, flag, v, "expected a preset name");
            o->animate = v;
            break;
        case OPT_PARAMS:
            if (v[0] != '{' || strlen(v) > 1000) return core_cli_bad(PROG, flag, v, "expected a JSON object");
            o->params = v;
            break;
        case OPT_DAEMON: o->daemon = v; break;
        case OPT_EDGES:
            for (const char *p = v; *p && !rc; p += strcspn(p, ",") + (p[strcspn(p, ",")] == ',')) {
                char item[8];
                size_t n = strcspn(p, ",");
                snprintf(item, sizeof item, "%.*s", (int)(n < sizeof item ? n : sizeof item - 1), p);
                if (o->nedge_list == MAX_EDGES || n >= sizeof item) rc = core_cli_bad(PROG, flag, v, "expected at most 8 counts");
                else if (!(rc = core_cli_u64(PROG, flag, item, 0, MAX_EDGES, &u))) o->edge_list[o->nedge_list++] = (int)u;
            }
            break;
        }
        if (rc) return rc;
    }
    if (status) return status;
    if (!o->ncases) {
        o->clients[0] = 1, o->clients[1] = 10, o->clients[2] = 100;
        o->ncases = 3;
    }
    return 0;
}

typedef struct fanout_result {
    int clients;
    double steps_per_s, fpc, fpc_min, mbytes_per_s, server_cpu, bench_cpu, skipped_per_s;
    double net_cpu;             /* the net thread's share, cores */
    double net_us_per_frame;    /* net thread CPU per frame delivered to one client */
    /* edge mode */
    double edge_cpu;            /* every edge's CPU together, cores */
    double edge_us_per_frame;   /* the edges' CPU per frame delivered to one client */
    double edge_net_us_per_frame; /* their net threads' share of it */
    double node_published_per_s;  /* frames the node published on NATS per second */
} fanout_result;

/* The processes of one case: the daemon (a simulation node in edge mode), and in edge mode
 * nats-server and the edges. */
typedef struct cluster {
    daemon_proc d;
    natsd nats;
    daemon_proc edges[MAX_EDGES];
    int nedges;
} cluster;

static void cluster_stop(cluster *c)
{
    for (int e = 0; e < c->nedges; e++) {
        int rc = daemon_stop(&c->edges[e], SIGTERM, 15000);
        if (rc != 0) fprintf(stderr, "fanout: edge %d exited with %d\n", e, rc);
    }
    int rc = daemon_stop(&c->d, SIGTERM, 15000);
    if (rc != 0) fprintf(stderr, "fanout: strandcastd exited with %d\n", rc);
    if (c->nedges) natsd_stop(&c->nats);
}

/* Starts the daemon (argv, NULL-terminated with room for 4 more) and, with o->edges, nats-server and
 * the edges. 0 on success (nothing left running otherwise). */
static int cluster_start(cluster *c, const fanout_opts *o, const char *exe, char **argv)
{
    memset(c, 0, sizeof *c);
    if (o->edges) {
        if (natsd_start(&c->nats, 0, NULL) != 0) {
            fprintf(stderr, "fanout: could not start nats-server (%s; .ci/deps installs it)\n", natsd_exe() ? natsd_exe() : "not installed");
            return 1;
        }
        int n = 0;
        while (argv[n]) n++;
        argv[n] = "--nats";
        argv[n + 1] = c->nats.url;
        argv[n + 2] = NULL;
    }
    if (daemon_start(&c->d, exe, argv, 30000) != 0) {
        fprintf(stderr, "fanout: could not start %s\n", exe);
        if (o->edges) natsd_stop(&c->nats);
        return 1;
    }
    for (; c->nedges < o->edges; c->nedges++) {
        char *eargv[] = { (char *)exe, "--relay", "--port", "0", "--nats", c->nats.url, NULL };
        if (daemon_start(&c->edges[c->nedges], exe, eargv, 30000) != 0) {
            fprintf(stderr, "fanout: could not start edge %d\n", c->nedges);
            cluster_stop(c);
            return 1;
        }
    }
    return 0;
}

/* The edges' CPU seconds: whole processes (or their net threads). */
static double edges_cpu_s(const cluster *c, bool net_only)
{
    double t = 0;
    for (int e = 0; e < c->nedges; e++) t += net_only ? thread_cpu_s(c->edges[e].pid, "sc-net") : proc_cpu_s(c->edges[e].pid);
    return t;
}

/* Reads the receivers (nrx sets) for ms milliseconds, keeping the lws control client serviced too. */
static void run_for(wsc *w, fanout_rx **rx, int nrx, int ms)
{
    for (double end = now_s() + ms / 1000.0; now_s() < end;) { /* ms = 0: nothing */
        for (int i = 0; i < nrx; i++) fanout_rx_run(rx[i], 100 / nrx);
        wsc_run(w, 0);
    }
}

/* Receiver k of the sets (clients are spread evenly: set i holds clients i, i + nrx, ...). */
static const fanout_rx_count *count_of(fanout_rx **rx, int nrx, int k) { return fanout_rx_count_of(rx[k % nrx], k / nrx); }

static int run_case(const fanout_opts *o, const char *exe, int nclients, fanout_result *res)
{
    char strands[16], verts[16];
    snprintf(strands, sizeof strands, "%d", o->strands ? o->strands : 4096);
    snprintf(verts, sizeof verts, "%d", o->verts ? o->verts : 32);
    char rate[32];
    snprintf(rate, sizeof rate, "%g", o->server_rate ? o->server_rate : 60.0);
    /* --min-step-rate 0: the scene asked for runs, however slowly (that is what is measured) */
    char *argv[16] = { (char *)exe, "--port", "0", "--strands", strands, "--verts", verts, "--rate", rate, "--min-step-rate", "0",
                       NULL };
    cluster cl;
    if (cluster_start(&cl, o, exe, argv)) return 1;
    daemon_proc d = cl.d;
    wsc *w = wsc_new();
    if (o->params || o->animate) {
        /* a control client changes the scene (parameters, head motion) and stays connected */
        wsc_conn *ctl = wsc_connect(w, d.port, "strandcast.v3", NULL, NULL);
        char msg[1100];
        bool ok = wsc_wait_open(w, ctl, 10000);
        if (ok && o->params) {
            snprintf(msg, sizeof msg, "{\"type\":\"set_params\",\"values\":%s}", o->params);
            wsc_send_text(ctl, msg);
            ok = wsc_next_of_type(w, ctl, "ok", 10000);
        }
        if (ok && o->animate) {
            snprintf(msg, sizeof msg, "{\"type\":\"animate\",\"preset\":\"%s\"}", o->animate);
            wsc_send_text(ctl, msg);
            ok = wsc_next_of_type(w, ctl, "ok", 10000);
        }
        if (!ok) {
            fprintf(stderr, "fanout: the daemon refused --params %s / --animate %s\n", o->params ? o->params : "-",
                    o->animate ? o->animate : "-");
            wsc_free(w);
            cluster_stop(&cl);
            return 1;
        }
    }
    char sub[96];
    snprintf(sub, sizeof sub, "{\"type\":\"subscribe\",\"max_rate\":%g}", o->max_rate);
    /* the receivers: on the daemon, or spread over the edges */
    int nrx = cl.nedges ? cl.nedges : 1;
    fanout_rx *rx[MAX_EDGES] = { 0 };
    for (int i = 0; i < nrx; i++) {
        int share = nclients / nrx + (i < nclients % nrx);
        rx[i] = fanout_rx_open(cl.nedges ? cl.edges[i].port : d.port, "strandcast.v3", share, sub);
        if (!rx[i]) {
            for (int k = 0; k < i; k++) fanout_rx_free(rx[k]);
            wsc_free(w);
            cluster_stop(&cl);
            return 1;
        }
    }
    run_for(w, rx, nrx, (int)(o->warmup * 1000)); /* hellos, keyframes, the hair settling */
    double steps0 = metric(d.port, "strandcast_steps_total");
    double skip0 = metric(d.port, "strandcast_frames_skipped_total");
    double pub0 = metric(d.port, "strandcast_nats_frames_published_total");
    double ecpu0 = edges_cpu_s(&cl, false), enet0 = edges_cpu_s(&cl, true);
    double cpu0 = proc_cpu_s(d.pid), net0 = thread_cpu_s(d.pid, "sc-net"), self0 = self_cpu_s(), t0 = now_s();
    uint64_t *f0 = calloc((size_t)(nclients ? nclients : 1), sizeof *f0), b0 = 0;
    for (int i = 0; i < nclients; i++) {
        f0[i] = count_of(rx, nrx, i)->frames;
        b0 += count_of(rx, nrx, i)->bytes;
    }
    run_for(w, rx, nrx, (int)(o->seconds * 1000));
    double t1 = now_s(), cpu1 = proc_cpu_s(d.pid), net1 = thread_cpu_s(d.pid, "sc-net"), self1 = self_cpu_s();
    double ecpu1 = edges_cpu_s(&cl, false), enet1 = edges_cpu_s(&cl, true);
    double steps1 = metric(d.port, "strandcast_steps_total");
    double skip1 = metric(d.port, "strandcast_frames_skipped_total");
    double pub1 = metric(d.port, "strandcast_nats_frames_published_total");
    double wall = t1 - t0;
    uint64_t total = 0, minf = UINT64_MAX, b1 = 0;
    int closed = 0;
    for (int i = 0; i < nclients; i++) {
        const fanout_rx_count *k = count_of(rx, nrx, i);
        uint64_t f = k->frames - f0[i];
        total += f;
        if (f < minf) minf = f;
        b1 += k->bytes;
        closed += k->closed;
    }
    if (closed) fprintf(stderr, "fanout: %d of %d receivers were disconnected by the server\n", closed, nclients);
    res->clients = nclients;
    res->steps_per_s = (steps1 - steps0) / wall;
    res->fpc = nclients ? (double)total / nclients / wall : 0;
    res->fpc_min = nclients ? (double)minf / wall : 0;
    res->mbytes_per_s = (double)(b1 - b0) / wall / 1e6;
    res->server_cpu = (cpu1 - cpu0) / wall;
    res->bench_cpu = (self1 - self0) / wall;
    res->skipped_per_s = (skip1 - skip0) / wall;
    res->net_cpu = (net1 - net0) / wall;
    res->net_us_per_frame = total ? (net1 - net0) / (double)total * 1e6 : 0;
    res->edge_cpu = (ecpu1 - ecpu0) / wall;
    res->edge_us_per_frame = total ? (ecpu1 - ecpu0) / (double)total * 1e6 : 0;
    res->edge_net_us_per_frame = total ? (enet1 - enet0) / (double)total * 1e6 : 0;
    res->node_published_per_s = cl.nedges ? (pub1 - pub0) / wall : 0;
    for (int i = 0; i < nrx; i++) fanout_rx_free(rx[i]);
    wsc_free(w);
    free(f0);
    cluster_stop(&cl);
    return 0;
}

/* One series: the baseline and every client count, with o->edges edges (0: none). */
static int run_edges(fanout_opts *o, const char *exe, long cores)
{
    fanout_result base;
    if (run_case(o, exe, 0, &base)) return 1;
    if (!o->json) {
        printf("fanout: %d strands x %d verts, server publishes %g frames/s, clients subscribe at max_rate %g, "
               "%g s per case, %ld cores\n",
               o->strands ? o->strands : 4096, o->verts ? o->verts : 32, o->server_rate ? o->server_rate : 60.0, o->max_rate,
               o->seconds, cores);
        if (o->params) printf("scene parameters changed with set_params %s\n", o->params);
        if (o->animate) printf("head motion: preset %s\n", o->animate);
        if (o->edges) printf("edge mode: a simulation node and %d edge relays over nats-server; server = the node\n", o->edges);
        printf("baseline (0 clients): %.1f sim steps/s, server CPU %.2f cores\n", base.steps_per_s, base.server_cpu);
        printf("%8s %9s %8s %12s %12s %8s %11s %9s %12s %10s", "clients", "steps/s", "vs base", "frames/cl/s",
               "min fr/cl/s", "MB/s", "server CPU", "net CPU", "net us/frame", "bench CPU");
        if (o->edges) printf(" %9s %13s %13s %10s", "edge CPU", "edge us/frame", "e.net us/fr", "node pub/s");
        printf("\n");
    }
    for (int i = 0; i < o->ncases; i++) {
        fanout_result r;
        if (run_case(o, exe, o->clients[i], &r)) return 1;
        double ratio = base.steps_per_s > 0 ? r.steps_per_s / base.steps_per_s : 0;
        if (o->json) {
            printf("{\"bench\":\"fanout\",\"clients\":%d,\"strands\":%d,\"verts\":%d,\"max_rate\":%g,\"server_rate\":%g,\"seconds\":%g,\"warmup_s\":%g,"
                   "\"sim_steps_per_s\":%.2f,\"baseline_steps_per_s\":%.2f,\"frames_per_client_per_s\":%.2f,"
                   "\"min_frames_per_client_per_s\":%.2f,\"mbytes_per_s\":%.3f,\"frames_skipped_per_s\":%.1f,"
                   "\"server_cpu\":%.3f,\"net_thread_cpu\":%.3f,\"net_us_per_client_frame\":%.1f,"
                   "\"bench_cpu\":%.3f,\"cores\":%ld,\"params\":%s,\"animate\":\"%s\",\"edges\":%d,\"edge_cpu\":%.3f,"
                   "\"edge_us_per_client_frame\":%.1f,\"edge_net_us_per_client_frame\":%.1f,\"node_published_per_s\":%.1f,"
                   "\"baseline_server_cpu\":%.3f}\n",
                   r.clients, o->strands ? o->strands : 4096, o->verts ? o->verts : 32, o->max_rate,
                   o->server_rate ? o->server_rate : 60.0, o->seconds, o->warmup, r.steps_per_s,
                   base.steps_per_s, r.fpc, r.fpc_min, r.mbytes_per_s, r.skipped_per_s, r.server_cpu, r.net_cpu,
                   r.net_us_per_frame, r.bench_cpu, cores,
                   o->params ? o->params : "null", o->animate ? o->animate : "none", o->edges, r.edge_cpu, r.edge_us_per_frame,
                   r.edge_net_us_per_frame, r.node_published_per_s, base.server_cpu);
        } else {
            printf("%8d %9.1f %7.2fx %12.1f %12.1f %8.2f %11.2f %9.3f %12.1f %10.2f", r.clients, r.steps_per_s, ratio,
                   r.fpc, r.fpc_min, r.mbytes_per_s, r.server_cpu, r.net_cpu, r.net_us_per_frame, r.bench_cpu);
            if (o->edges) printf(" %9.2f %13.1f %13.1f %10.1f", r.edge_cpu, r.edge_us_per_frame, r.edge_net_us_per_frame,
                                r.node_published_per_s);
            printf("\n");
        }
        fflush(stdout);
    }
    return 0;
}

int bench_fanout_main(int argc, char **argv)
{
    fanout_opts o = { 0 };
    int rc = parse_opts(argc, argv, &o);
    if (rc) return rc == 1 ? 0 : rc;
    char buf[PATH_MAX];
    const char *exe = bench_find_daemon(o.daemon, buf, sizeof buf);
    if (!exe) {
        fprintf(stderr, "fanout: strandcastd not found next to strandbench; pass --daemon PATH\n");
        return 2;
    }
    signal(SIGPIPE, SIG_IGN);
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    for (int k = 0; k < (o.nedge_list ? o.nedge_list : 1); k++) {
        o.edges = o.nedge_list ? o.edge_list[k] : 0;
        if (run_edges(&o, exe, cores)) return 1;
    }
    return 0;
}

