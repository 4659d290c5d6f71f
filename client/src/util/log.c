/* The process's log sink (corvid/log.h): level filter, callback, stderr default. */
#include "corvid/log.h"

#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>

/* process-wide: one sink per process, as stderr is; the program sets it at start and every library
 * thread writes through it. The lock serialises the callback with itself and with a change of sink. */
static pthread_mutex_t sink_lock = PTHREAD_MUTEX_INITIALIZER;
/* process-wide: the sink's callback and its argument (guarded by sink_lock). */
static cv_log_fn sink_fn;
static void *sink_user;
/* process-wide: the sink's level, read without the lock so that a disabled level costs one load. */
static atomic_int sink_max_level = CV_LOG_INFO;

void cv_log_set_sink(cv_log_fn fn, void *user, cv_log_level max_level) {
    pthread_mutex_lock(&sink_lock);
    sink_fn = fn;
    sink_user = user;
    atomic_store_explicit(&sink_max_level, (int)max_level, memory_order_relaxed);
    pthread_mutex_unlock(&sink_lock);
}

bool cv_log_enabled(cv_log_level level) {
    return (int)level <= atomic_load_explicit(&sink_max_level, memory_order_relaxed);
}

static void deliver(cv_log_level level, const char *origin, const char *message) {
    pthread_mutex_lock(&sink_lock);
    bool still_enabled = cv_log_enabled(level); /* the level may have been lowered since the caller's check */
    if (still_enabled && sink_fn)
        sink_fn(level, origin, message, sink_user);
    else if (still_enabled)
        fprintf(stderr, "corvid %s: %s\n", origin, message);
    pthread_mutex_unlock(&sink_lock);
}

void cv_log(cv_log_level level, const char *origin, const char *fmt, ...) {
    if (!cv_log_enabled(level))
        return;
    if (!origin)
        origin = "?";
    char message[1024];
    va_list ap, again;
    va_start(ap, fmt);
    va_copy(again, ap);
    int len = vsnprintf(message, sizeof(message), fmt, ap);
    va_end(ap);
    /* A long message is built on the heap; out of memory, its start is still worth a line. */
    char *full = len >= (int)sizeof(message) ? malloc((size_t)len + 1) : NULL;
    if (full)
        vsnprintf(full, (size_t)len + 1, fmt, again);
    va_end(again);
    deliver(level, origin, full ? full : message);
    free(full);
}
