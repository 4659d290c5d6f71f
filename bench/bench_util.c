/* Benchmark helpers: clock, parallel loop, machine description. */
#include "bench_util.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "corvid/clock.h"

#define MAX_THREADS 256

double bench_now(void) { return (double)cv_now_ns() * 1e-9; }

typedef struct loop {
    bench_range_fn fn;
    void *ctx;
    size_t count, chunk;
    atomic_size_t next;
} loop;

static void *run(void *p) {
    loop *l = p;
    for (;;) {
        size_t begin = atomic_fetch_add(&l->next, l->chunk);
        if (begin >= l->count)
            return NULL;
        l->fn(l->ctx, begin, begin + l->chunk < l->count ? begin + l->chunk : l->count);
    }
}

void bench_parallel(uint32_t threads, size_t count, size_t chunk, bench_range_fn fn, void *ctx) {
    loop l = { .fn = fn, .ctx = ctx, .count = count, .chunk = chunk ? chunk : 1 };
    atomic_init(&l.next, 0);
    pthread_t tids[MAX_THREADS];
    uint32_t started = 0;
    for (uint32_t i = 1; i < threads && i < MAX_THREADS; i++) {
        if (pthread_create(&tids[started], NULL, run, &l) != 0)
            break;
        started++;
    }
    run(&l);
    for (uint32_t i = 0; i < started; i++)
        pthread_join(tids[i], NULL);
}

void bench_machine(char *buf, size_t size) {
    char model[256] = "unknown CPU", line[512];
    FILE *f = fopen("/proc/cpuinfo", "r");
    while (f && fgets(line, sizeof line, f)) {
        char *colon = strchr(line, ':');
        if (strncmp(line, "model name", 10) == 0 && colon) {
            snprintf(model, sizeof model, "%s", colon + 2);
            model[strcspn(model, "\n")] = 0;
            break;
        }
    }
    if (f)
        fclose(f);
    snprintf(buf, size, "%s, %ld online CPUs", model, sysconf(_SC_NPROCESSORS_ONLN));
}
