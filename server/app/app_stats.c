/* app: the published stats board and its Prometheus text. */
#include <stdio.h>
#include <string.h>

#include "app_stats.h"

void app_stats_board_init(app_stats_board *b)
{
    memset(b, 0, sizeof *b);
    pthread_mutex_init(&b->mu, NULL);
}

void app_stats_board_free(app_stats_board *b) { pthread_mutex_destroy(&b->mu); }

app_stats app_stats_read(app_stats_board *b)
{
    pthread_mutex_lock(&b->mu);
    app_stats s = b->s;
    pthread_mutex_unlock(&b->mu);
    return s;
}

size_t app_stats_metrics(const app_stats *sp, uint64_t accepted, uint64_t rejected, char *buf, size_t cap)
{
    const app_stats s = *sp;
    int w = snprintf(buf, cap,
                     "# HELP strandcast_steps_per_second Simulation steps per second (last second).\n"
                     "# TYPE strandcast_steps_per_second gauge\nstrandcast_steps_per_second %.3f\n"
                     "# HELP strandcast_step_seconds Mean wall time of one simulation step (last second).\n"
                     "# TYPE strandcast_step_seconds gauge\nstrandcast_step_seconds %.6f\n"
                     "# HELP strandcast_steps_total Simulation steps run since the daemon started.\n"
                     "# TYPE strandcast_steps_total counter\nstrandcast_steps_total %llu\n"
                     "# HELP strandcast_sim_steps Steps of the current simulation (since start, reset or groom change).\n"
                     "# TYPE strandcast_sim_steps gauge\nstrandcast_sim_steps %llu\n"
                     "# HELP strandcast_sim_time_seconds Simulated time since start or reset.\n"
                     "# TYPE strandcast_sim_time_seconds gauge\nstrandcast_sim_time_seconds %.6f\n"
                     "# HELP strandcast_encode_seconds Mean wall time to encode one frame round, all streams (last second).\n"
                     "# TYPE strandcast_encode_seconds gauge\nstrandcast_encode_seconds %.6f\n"
                     "# HELP strandcast_frames_encoded_total Frames encoded (once per stream, shared by its clients).\n"
                     "# TYPE strandcast_frames_encoded_total counter\nstrandcast_frames_encoded_total %llu\n"
                     "# HELP strandcast_encoded_bytes_total Bytes of encoded frames.\n"
                     "# TYPE strandcast_encoded_bytes_total counter\nstrandcast_encoded_bytes_total %llu\n"
                     "# HELP strandcast_steps_abandoned_total Steps abandoned part way to take a parameter change at once, then taken again.\n"
                     "# TYPE strandcast_steps_abandoned_total counter\nstrandcast_steps_abandoned_total %llu\n"
                     "# HELP strandcast_nan_resets_total Strands restored to rest after a non-finite value, since the daemon started.\n"
                     "# TYPE strandcast_nan_resets_total counter\nstrandcast_nan_resets_total %llu\n"
                     "# HELP strandcast_control_messages_total Client control messages by outcome.\n"
                     "# TYPE strandcast_control_messages_total counter\n"
                     "strandcast_control_messages_total{result=\"accepted\"} %llu\n"
                     "strandcast_control_messages_total{result=\"rejected\"} %llu\n",
                     s.steps_per_s, s.step_ms / 1e3, (unsigned long long)s.steps_run, (unsigned long long)s.steps,
                     s.sim_time, s.encode_ms / 1e3, (unsigned long long)s.frames_encoded,
                     (unsigned long long)s.encode_bytes, (unsigned long long)s.steps_abandoned, (unsigned long long)s.nan_resets_run, (unsigned long long)accepted,
                     (unsigned long long)rejected);
    if (w < 0) return 0;
    return (size_t)w < cap ? (size_t)w : cap - 1;
}
