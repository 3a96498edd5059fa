/* pool.c: a pthreads pool. A job is `count` independent tasks handed out through an atomic
 * counter; the caller's thread works too. Which thread runs a task never changes the result:
 * callers decompose work so that each task's output depends on its index only. */
#include "obs.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <unistd.h>

struct obs_pool {
    int threads;                 /* including the caller */
    pthread_t *workers;          /* threads - 1 */
    pthread_mutex_t lock;
    pthread_cond_t wake, done;
    /* the current job */
    uint64_t generation;
    obs_task_fn fn;
    void *user;
    int64_t count;
    atomic_int_fast64_t next;
    int active;                  /* workers still inside the current job */
    int quit;
};

typedef struct worker_arg { obs_pool *pool; int index; } worker_arg;

static void run_tasks(obs_pool *p, obs_task_fn fn, void *user, int64_t count, int thread)
{
    for (;;) {
        int64_t t = atomic_fetch_add(&p->next, 1);
        if (t >= count)
            break;
        fn(user, t, thread);
    }
}

static void *worker_main(void *arg)
{
    worker_arg wa = *(worker_arg *)arg;
    free(arg);
    obs_pool *p = wa.pool;
    uint64_t seen = 0;
    pthread_mutex_lock(&p->lock);
    for (;;) {
        while (!p->quit && p->generation == seen)
            pthread_cond_wait(&p->wake, &p->lock);
        if (p->quit)
            break;
        seen = p->generation;
        obs_task_fn fn = p->fn;
        void *user = p->user;
        int64_t count = p->count;
        pthread_mutex_unlock(&p->lock);
        run_tasks(p, fn, user, count, wa.index);
        pthread_mutex_lock(&p->lock);
        if (--p->active == 0)
            pthread_cond_signal(&p->done);
    }
    pthread_mutex_unlock(&p->lock);
    return NULL;
}

obs_pool *obs_pool_create(int threads)
{
    if (threads <= 0) {
        long n = sysconf(_SC_NPROCESSORS_ONLN);
        threads = n > 0 ? (int)n : 1;
    }
    if (threads > 256)
        threads = 256;
    obs_pool *p = (obs_pool *)calloc(1, sizeof *p);
    if (!p)
        return NULL;
    p->threads = threads;
    atomic_init(&p->next, 0);
    pthread_mutex_init(&p->lock, NULL);
    pthread_cond_init(&p->wake, NULL);
    pthread_cond_init(&p->done, NULL);
    if (threads > 1) {
        p->workers = (pthread_t *)calloc((size_t)threads - 1, sizeof(pthread_t));
        if (!p->workers) {
            obs_pool_destroy(p);
            return NULL;
        }
        for (int i = 0; i < threads - 1; i++) {
            worker_arg *wa = (worker_arg *)malloc(sizeof *wa);
            if (wa) {
                wa->pool = p;
                wa->index = i + 1;
            }
            if (!wa || pthread_create(&p->workers[i], NULL, worker_main, wa) != 0) {
                free(wa);
                p->threads = i + 1; /* only i workers started */
                obs_pool_destroy(p);
                return NULL;
            }
        }
    }
    return p;
}

void obs_pool_destroy(obs_pool *p)
{
    if (!p)
        return;
    if (p->workers) {
        pthread_mutex_lock(&p->lock);
        p->quit = 1;
        pthread_cond_broadcast(&p->wake);
        pthread_mutex_unlock(&p->lock);
        for (int i = 0; i < p->threads - 1; i++)
            pthread_join(p->workers[i], NULL);
        free(p->workers);
    }
    pthread_mutex_destroy(&p->lock);
    pthread_cond_destroy(&p->wake);
    pthread_cond_destroy(&p->done);
    free(p);
}

int obs_pool_threads(const obs_pool *p) { return p ? p->threads : 1; }

void obs_pool_run(obs_pool *p, int64_t count, obs_task_fn fn, void *user)
{
    if (count <= 0)
        return;
    if (!p || p->threads == 1 || count == 1) {
        for (int64_t t = 0; t < count; t++)
            fn(user, t, 0);
        return;
    }
    pthread_mutex_lock(&p->lock);
    p->fn = fn;
    p->user = user;
    p->count = count;
    atomic_store(&p->next, 0);
    p->active = p->threads - 1;
    p->generation++;
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->lock);

    run_tasks(p, fn, user, count, 0);

    pthread_mutex_lock(&p->lock);
    while (p->active > 0)
        pthread_cond_wait(&p->done, &p->lock);
    pthread_mutex_unlock(&p->lock);
}

obs_tiling obs_tiling_make(int width, int height, int tile)
{
    obs_tiling t;
    if (tile < 1)
        tile = 1;
    t.width = width > 0 ? width : 0;
    t.height = height > 0 ? height : 0;
    t.tile = tile;
    t.tiles_x = (t.width + tile - 1) / tile;
    t.tiles_y = (t.height + tile - 1) / tile;
    return t;
}

void obs_tiling_rect(const obs_tiling *t, int64_t index, int *x0, int *y0, int *x1, int *y1)
{
    int tx = (int)(index % t->tiles_x), ty = (int)(index / t->tiles_x);
    *x0 = tx * t->tile;
    *y0 = ty * t->tile;
    *x1 = *x0 + t->tile < t->width ? *x0 + t->tile : t->width;
    *y1 = *y0 + t->tile < t->height ? *y0 + t->tile : t->height;
}
