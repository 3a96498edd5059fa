/* timer.c: monotonic wall-clock timers. */
#include "obs.h"

#include <time.h>

double obs_time_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void obs_timer_start(obs_timer *t)
{
    t->start = obs_time_now();
    t->running = 1;
}

void obs_timer_stop(obs_timer *t)
{
    if (t->running) {
        t->elapsed += obs_time_now() - t->start;
        t->running = 0;
    }
}

double obs_timer_seconds(const obs_timer *t)
{
    return t->elapsed + (t->running ? obs_time_now() - t->start : 0.0);
}
