/* Parallel loop: workers claim chunks from an atomic counter until none is left. */
#include "parallel.h"

#include <pthread.h>
#include <stdatomic.h>
#include <unistd.h>

uint32_t cvs_thread_count(uint32_t requested) {
    long n = requested ? (long)requested : sysconf(_SC_NPROCESSORS_ONLN);
    if (n < 1)
        n = 1;
    if (n > (long)CVS_MAX_THREADS)
        n = CVS_MAX_THREADS;
    return (uint32_t)n;
}

typedef struct loop {
    cvs_range_fn fn;
    void *ctx;
    size_t count, chunk;
    atomic_size_t next;
} loop;

typedef struct worker_arg {
    loop *l;
    uint32_t worker;
} worker_arg;

static void run_chunks(loop *l, uint32_t worker) {
    for (;;) {
        size_t begin = atomic_fetch_add(&l->next, l->chunk);
        if (begin >= l->count)
            return;
        size_t end = begin + l->chunk < l->count ? begin + l->chunk : l->count;
        l->fn(l->ctx, begin, end, worker);
    }
}

static void *worker_main(void *p) {
    worker_arg *a = p;
    run_chunks(a->l, a->worker);
    return NULL;
}

void cvs_parallel_for(uint32_t threads, size_t count, size_t chunk, cvs_range_fn fn, void *ctx) {
    if (count == 0)
        return;
    if (chunk == 0)
        chunk = 1;
    size_t chunks = (count + chunk - 1) / chunk;
    if (threads > chunks)
        threads = (uint32_t)chunks;
    if (threads > CVS_MAX_THREADS)
        threads = CVS_MAX_THREADS;
    loop l = { .fn = fn, .ctx = ctx, .count = count, .chunk = chunk };
    atomic_init(&l.next, 0);
    pthread_t tids[CVS_MAX_THREADS];
    worker_arg args[CVS_MAX_THREADS];
    uint32_t started = 1; /* the caller is worker 0 */
    while (started < threads) {
        args[started] = (worker_arg){ &l, started };
        if (pthread_create(&tids[started], NULL, worker_main, &args[started]) != 0)
            break;
        started++;
    }
    run_chunks(&l, 0);
    for (uint32_t i = 1; i < started; i++)
        pthread_join(tids[i], NULL);
}
