/* Cross-device GPU waits through a host thread (see vk_bridge.h). */
#include <stdlib.h>
#include <string.h>

#include "vk_instance.h"

#include "vk_bridge.h"

/* A bridge thread re-checks a closing device this often while it waits. */
#define WATCH_POLL_NS (50ull * 1000 * 1000)

/* The bridge of one device: its semaphore, its own watch and the request ring. */
typedef struct vk_bridge_request_item {
    vk_watch *watch; /* a reference */
    uint64_t ticket; /* wait until the watched device reached it */
    uint64_t value;  /* then signal this */
} vk_bridge_request_item;

struct vk_bridge {
    VkSemaphore semaphore; /* timeline, on this device */
    vk_watch *watch;       /* this device's own ticket semaphore, for other bridges */
    pthread_mutex_t lock;
    pthread_cond_t changed;
    pthread_t thread;
    bool started, stop;
    uint64_t value; /* the last value handed out (under lock) */
    vk_bridge_request_item *queue;
    uint32_t head, count, capacity; /* a ring */
};

struct vk_watch {
    atomic_uint refs;
    pthread_mutex_t lock;
    pthread_cond_t idle;
    uint32_t users;        /* bridge threads inside a wait on the semaphore */
    bool closing;          /* the device is being destroyed: its tickets are all done */
    cv_backend_device *bd; /* valid while !closing (users keep it so) */
    VkSemaphore semaphore;
};

void vk_watch_ref(vk_watch *w) { atomic_fetch_add(&w->refs, 1); }

void vk_watch_unref(vk_watch *w) {
    if (atomic_fetch_sub(&w->refs, 1) != 1)
        return;
    pthread_cond_destroy(&w->idle);
    pthread_mutex_destroy(&w->lock);
    free(w);
}

bool vk_watch_closing(vk_watch *w) {
    pthread_mutex_lock(&w->lock);
    bool closing = w->closing;
    pthread_mutex_unlock(&w->lock);
    return closing;
}

/* Waits until the watched device reached `ticket` (or is closing). */
static void watch_wait(vk_watch *w, uint64_t ticket, const bool *stop, pthread_mutex_t *stop_lock) {
    pthread_mutex_lock(&w->lock);
    bool closing = w->closing;
    if (!closing)
        w->users++;
    pthread_mutex_unlock(&w->lock);
    if (closing)
        return;
    VkSemaphoreWaitInfo info = { .sType = VK_STRUCTURE_TYPE_SEMAPHORE_WAIT_INFO,
                                 .semaphoreCount = 1,
                                 .pSemaphores = &w->semaphore,
                                 .pValues = &ticket };
    for (;;) {
        VkResult vr = vk_host_wait(w->bd, &info, WATCH_POLL_NS);
        if (vr != VK_TIMEOUT)
            break; /* reached, or the device failed: nothing more to wait for */
        pthread_mutex_lock(&w->lock);
        closing = w->closing;
        pthread_mutex_unlock(&w->lock);
        pthread_mutex_lock(stop_lock);
        bool stopping = *stop;
        pthread_mutex_unlock(stop_lock);
        if (closing || stopping)
            break;
    }
    pthread_mutex_lock(&w->lock);
    w->users--;
    pthread_cond_broadcast(&w->idle);
    pthread_mutex_unlock(&w->lock);
}

static void *bridge_thread(void *arg) {
    cv_backend_device *bd = arg;
    vk_bridge *b = bd->bridge;
    vk_layer_urgent_thread();
    for (;;) {
        pthread_mutex_lock(&b->lock);
        while (!b->count && !b->stop)
            pthread_cond_wait(&b->changed, &b->lock);
        if (!b->count) {
            pthread_mutex_unlock(&b->lock);
            return NULL;
        }
        vk_bridge_request_item it = b->queue[b->head];
        bool stopping = b->stop;
        pthread_mutex_unlock(&b->lock);
        if (!stopping)
            watch_wait(it.watch, it.ticket, &b->stop, &b->lock);
        vk_watch_unref(it.watch);
        VkSemaphoreSignalInfo signal = { .sType = VK_STRUCTURE_TYPE_SEMAPHORE_SIGNAL_INFO,
                                         .semaphore = b->semaphore,
                                         .value = it.value };
        vk_host_signal(bd, &signal);
        pthread_mutex_lock(&b->lock);
        b->head = (b->head + 1) % b->capacity;
        b->count--;
        pthread_mutex_unlock(&b->lock);
    }
}

cv_result vk_bridge_init(cv_backend_device *bd) {
    vk_bridge *b = calloc(1, sizeof(*b));
    vk_watch *w = calloc(1, sizeof(*w));
    if (!b || !w) {
        free(b);
        free(w);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "device '%s': bridge", bd->label);
    }
    cv_result r = vk_device_create_timeline(bd, &b->semaphore, "bridge", false);
    if (r != CV_OK) {
        free(b);
        free(w);
        return r;
    }
    atomic_init(&w->refs, 1);
    pthread_mutex_init(&w->lock, NULL);
    pthread_cond_init(&w->idle, NULL);
    w->bd = bd;
    w->semaphore = bd->ticket;
    b->watch = w;
    pthread_mutex_init(&b->lock, NULL);
    pthread_cond_init(&b->changed, NULL);
    bd->bridge = b;
    return CV_OK;
}

void vk_bridge_finish(cv_backend_device *bd) {
    vk_bridge *b = bd->bridge;
    if (!b)
        return;
    /* No bridge of another device may be inside a wait on us once we go. */
    pthread_mutex_lock(&b->watch->lock);
    b->watch->closing = true;
    while (b->watch->users)
        pthread_cond_wait(&b->watch->idle, &b->watch->lock);
    pthread_mutex_unlock(&b->watch->lock);
    vk_watch_unref(b->watch);
    b->watch = NULL;
    pthread_mutex_lock(&b->lock);
    b->stop = true;
    pthread_cond_broadcast(&b->changed);
    bool started = b->started;
    pthread_mutex_unlock(&b->lock);
    if (started)
        pthread_join(b->thread, NULL);
    free(b->queue);
    pthread_cond_destroy(&b->changed);
    pthread_mutex_destroy(&b->lock);
    vkDestroySemaphore(bd->device, b->semaphore, NULL);
    free(b);
    bd->bridge = NULL;
}

cv_result vk_bridge_request(cv_backend_device *bd, cv_backend_device *other, uint64_t ticket, uint64_t *value) {
    vk_bridge *b = bd->bridge;
    pthread_mutex_lock(&b->lock);
    cv_result r = CV_OK;
    if (b->count == b->capacity) {
        uint32_t cap = b->capacity ? b->capacity * 2 : 16;
        vk_bridge_request_item *q = malloc(cap * sizeof(*q));
        if (!q) {
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "device '%s': bridge queue of %u", bd->label, cap);
        } else {
            for (uint32_t i = 0; i < b->count; i++)
                q[i] = b->queue[(b->head + i) % b->capacity];
            free(b->queue);
            b->queue = q;
            b->head = 0;
            b->capacity = cap;
        }
    }
    if (r == CV_OK && !b->started) {
        if (pthread_create(&b->thread, NULL, bridge_thread, bd) != 0)
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "device '%s': cannot start the bridge thread", bd->label);
        else
            b->started = true;
    }
    if (r == CV_OK) {
        vk_watch *w = other->bridge->watch;
        vk_watch_ref(w);
        *value = ++b->value;
        b->queue[(b->head + b->count) % b->capacity] = (vk_bridge_request_item){ w, ticket, *value };
        b->count++;
        pthread_cond_broadcast(&b->changed);
    }
    pthread_mutex_unlock(&b->lock);
    return r;
}

vk_watch *vk_bridge_watch(const cv_backend_device *bd) { return bd->bridge->watch; }

VkSemaphore vk_bridge_semaphore(const cv_backend_device *bd) { return bd->bridge->semaphore; }
