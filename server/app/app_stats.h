/* app: the numbers the sim thread publishes for the stats message and /metrics, behind one
 * mutex (the sim thread writes, the net thread reads). */
#ifndef APP_STATS_H
#define APP_STATS_H

#include <pthread.h>
#include <stddef.h>
#include <stdint.h>

typedef struct app_stats {
    uint64_t steps_run;       /* steps since the daemon started (never reset) */
    uint64_t nan_resets_run;  /* NaN restores since the daemon started (never reset) */
    uint64_t steps_abandoned; /* steps abandoned for a change and taken again (never reset) */
    uint64_t steps;           /* the sim's own count: since start, reset or groom change */
    double sim_time;
    double steps_per_s;       /* over the last stats window */
    double step_ms;           /* mean over the last stats window */
    double encode_ms;         /* mean per published round over the last window */
    uint64_t frames_encoded, encode_bytes, nan_resets; /* nan_resets: of the current sim, since reset */
    uint32_t clients;
} app_stats;

/* The published copy and its lock. */
typedef struct app_stats_board {
    pthread_mutex_t mu;
    app_stats s;
} app_stats_board;

/* A zeroed board; app_stats_board_free releases its lock. */
void app_stats_board_init(app_stats_board *b);
void app_stats_board_free(app_stats_board *b);
/* A copy of the published numbers. Any thread. */
app_stats app_stats_read(app_stats_board *b);
/* Prometheus text of s and the control-message counters into buf (at most cap - 1 bytes and a
 * NUL); returns the length. Pure. */
size_t app_stats_metrics(const app_stats *s, uint64_t accepted, uint64_t rejected, char *buf, size_t cap);

#endif
