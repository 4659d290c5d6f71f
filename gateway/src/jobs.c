/* The gateway's jobs: table, queue and workers (jobs.h). */
#include "jobs.h"

#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "corvid/scene_procedural.h"
#include "job_render.h"

typedef enum job_state { JOB_QUEUED, JOB_RUNNING, JOB_DONE, JOB_FAILED, JOB_CANCELLED } job_state;

static const char *const state_names[] = { "queued", "running", "done", "failed", "cancelled" };

typedef struct job {
    uint64_t id;
    job_state state;
    bool cancel_requested; /* a DELETE came; a running job ends cancelled at its next frame */
    atomic_bool cancel;    /* read by the render between frames */
    uint32_t frames_done;
    char scene_sha[CV_SHA256_HEX_SIZE];
    const gw_scene *scene; /* the store's reference while queued or running; NULL: the built-in room */
    cv_render_settings settings;
    char error[1024];
    gw_render_result images;
    struct job *next;       /* the table, oldest first */
    struct job *queue_next; /* the queue, first come first */
} job;

struct gw_jobs {
    gw_jobs_config config;
    pthread_mutex_t lock;
    pthread_cond_t work;    /* a job was queued, or stopping */
    pthread_cond_t changed; /* a job's state or frames changed */
    bool stopping;
    uint64_t next_id;
    uint32_t queued, kept;
    job *table, *queue;
    pthread_t workers[64];
    uint32_t worker_count;
    /* The built-in room, made by the first job on it and shared (read only) by the later ones. */
    pthread_mutex_t room_lock;
    cv_scene *room;
    cv_bvh *room_bvh;
};

static void jobs_log(gw_jobs *j, cv_log_level level, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void jobs_log(gw_jobs *j, cv_log_level level, const char *fmt, ...) {
    char message[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(message, sizeof(message), fmt, ap);
    va_end(ap);
    if (j->config.log)
        j->config.log(level, "gateway", message, j->config.log_user);
    else
        cv_log(level, "gateway", "%s", message);
}

static job *find(gw_jobs *j, uint64_t id) {
    for (job *b = j->table; b; b = b->next)
        if (b->id == id)
            return b;
    return NULL;
}

static bool ended(const job *b) {
    return b->state == JOB_DONE || b->state == JOB_FAILED || b->state == JOB_CANCELLED;
}

/* With the lock held: the job leaves the queue, or its render, in state `s`; its scene reference goes. */
static void end_job(gw_jobs *j, job *b, job_state s) {
    b->state = s;
    gw_store_release(j->config.store, b->scene);
    b->scene = NULL;
    pthread_cond_broadcast(&j->changed);
}

typedef struct progress_relay {
    gw_jobs *jobs;
    job *job;
} progress_relay;

static void relay_progress(uint32_t frames_done, void *user) {
    progress_relay *p = user;
    pthread_mutex_lock(&p->jobs->lock);
    p->job->frames_done = frames_done;
    pthread_cond_broadcast(&p->jobs->changed);
    pthread_mutex_unlock(&p->jobs->lock);
}

/* The built-in room and its BVH, made once. */
static cv_result room_scene(gw_jobs *j, const cv_scene **scene, const cv_bvh **bvh) {
    pthread_mutex_lock(&j->room_lock);
    cv_result r = CV_OK;
    if (!j->room) {
        cv_scene *s = NULL;
        cv_bvh *b = NULL;
        r = cv_scene_make_room(1, &s);
        if (r == CV_OK)
            r = cv_bvh_build_flat(s, NULL, &b);
        if (r == CV_OK) {
            j->room = s;
            j->room_bvh = b;
        } else {
            cv_scene_destroy(s);
        }
    }
    *scene = j->room;
    *bvh = j->room_bvh;
    pthread_mutex_unlock(&j->room_lock);
    return r;
}

/* Runs one job (the lock not held): devices, render, images. */
static cv_result run_job(gw_jobs *j, job *b, gw_render_result *images) {
    cv_gateway_devices devices = { 0 };
    if (atomic_load(&b->cancel)) { /* cancelled as it left the queue: no devices opened for nothing */
        images->cancelled = true;
        return CV_OK;
    }
    const cv_scene *scene = b->scene ? b->scene->scene : NULL;
    const cv_bvh *bvh = b->scene ? b->scene->bvh : NULL;
    cv_result r = b->scene ? CV_OK : room_scene(j, &scene, &bvh);
    if (r == CV_OK && (r = j->config.open_devices(j->config.user, &devices)) != CV_OK)
        r = cv_error(r, "devices: %s", cv_last_error());
    if (r == CV_OK && devices.count == 0)
        r = cv_error(CV_ERROR_NOT_FOUND, "devices: the program opened none");
    progress_relay relay = { .jobs = j, .job = b };
    if (r == CV_OK)
        r = gw_render_run(&(gw_render_input){ .scene = scene,
                                              .bvh = bvh,
                                              .settings = b->settings,
                                              .devices = &devices,
                                              .cancel = &b->cancel,
                                              .progress = relay_progress,
                                              .user = &relay,
                                              .temp_dir = j->config.temp_dir },
                          images);
    /* Closing a lost device may record errors of its own: the job's is the one it failed with. */
    char error[CV_ERROR_MESSAGE_MAX];
    snprintf(error, sizeof(error), "%s", r == CV_OK ? "" : cv_last_error());
    gw_devices_close(&devices);
    return r == CV_OK ? CV_OK : cv_error(r, "%s", error);
}

static void *worker_main(void *arg) {
    gw_jobs *j = arg;
    pthread_mutex_lock(&j->lock);
    for (;;) {
        while (!j->queue && !j->stopping)
            pthread_cond_wait(&j->work, &j->lock);
        if (!j->queue)
            break;
        job *b = j->queue;
        j->queue = b->queue_next;
        j->queued--;
        b->state = JOB_RUNNING;
        pthread_cond_broadcast(&j->changed);
        pthread_mutex_unlock(&j->lock);
        jobs_log(j, CV_LOG_INFO, "job %llu: rendering %ux%u, %u frames", (unsigned long long)b->id, b->settings.width,
                 b->settings.height, b->settings.frames);
        gw_render_result images = { 0 };
        cv_result r = run_job(j, b, &images);
        char error[sizeof(b->error)];
        snprintf(error, sizeof(error), "%s", r == CV_OK ? "" : cv_last_error());
        if (r != CV_OK)
            jobs_log(j, CV_LOG_WARNING, "job %llu failed: %s", (unsigned long long)b->id, error);
        pthread_mutex_lock(&j->lock);
        memcpy(b->error, error, sizeof(error));
        b->images = images;
        end_job(j, b, r != CV_OK ? JOB_FAILED : images.cancelled ? JOB_CANCELLED : JOB_DONE);
    }
    pthread_mutex_unlock(&j->lock);
    return NULL;
}

static void job_free(job *b) {
    gw_render_result_free(&b->images);
    free(b);
}

void gw_jobs_destroy(gw_jobs *j) {
    if (!j)
        return;
    pthread_mutex_lock(&j->lock);
    j->stopping = true;
    for (job *b = j->queue; b; b = b->queue_next)
        end_job(j, b, JOB_CANCELLED);
    j->queue = NULL;
    j->queued = 0;
    for (job *b = j->table; b; b = b->next)
        atomic_store(&b->cancel, true);
    pthread_cond_broadcast(&j->work);
    pthread_mutex_unlock(&j->lock);
    for (uint32_t i = 0; i < j->worker_count; i++)
        pthread_join(j->workers[i], NULL);
    while (j->table) {
        job *b = j->table;
        j->table = b->next;
        job_free(b);
    }
    cv_bvh_destroy(j->room_bvh);
    cv_scene_destroy(j->room);
    pthread_cond_destroy(&j->work);
    pthread_cond_destroy(&j->changed);
    pthread_mutex_destroy(&j->room_lock);
    pthread_mutex_destroy(&j->lock);
    free(j);
}

cv_result gw_jobs_create(const gw_jobs_config *config, gw_jobs **out) {
    gw_jobs *j = calloc(1, sizeof(*j));
    if (!j)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "gateway: jobs");
    j->config = *config;
    j->next_id = 1;
    pthread_mutex_init(&j->lock, NULL);
    pthread_mutex_init(&j->room_lock, NULL);
    pthread_cond_init(&j->work, NULL);
    pthread_condattr_t attr;
    pthread_condattr_init(&attr);
    pthread_condattr_setclock(&attr, CLOCK_MONOTONIC);
    pthread_cond_init(&j->changed, &attr);
    pthread_condattr_destroy(&attr);
    cv_result r = CV_OK;
    for (uint32_t i = 0; r == CV_OK && i < config->workers; i++) {
        if (pthread_create(&j->workers[i], NULL, worker_main, j) != 0)
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "gateway: cannot start worker thread %u", i);
        else
            j->worker_count++;
    }
    if (r != CV_OK) {
        gw_jobs_destroy(j);
        return r;
    }
    *out = j;
    return CV_OK;
}

/* With the lock held: room in the table for one more job (the oldest ended one dropped), or false. */
static bool make_room(gw_jobs *j) {
    if (j->kept < j->config.max_jobs)
        return true;
    for (job **p = &j->table; *p; p = &(*p)->next) {
        if (ended(*p)) {
            job *b = *p;
            *p = b->next;
            job_free(b);
            j->kept--;
            return true;
        }
    }
    return false;
}

cv_result gw_jobs_submit(gw_jobs *j, const gw_job_request *req, const gw_scene *scene, uint64_t *id) {
    job *b = calloc(1, sizeof(*b));
    if (!b) {
        gw_store_release(j->config.store, scene);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "jobs: a new job");
    }
    memcpy(b->scene_sha, req->scene, sizeof(b->scene_sha));
    b->scene = scene;
    b->settings = req->settings;
    atomic_init(&b->cancel, false);
    pthread_mutex_lock(&j->lock);
    cv_result r = CV_OK;
    if (j->stopping)
        r = cv_error(CV_ERROR_BAD_STATE, "jobs: the gateway is stopping");
    else if (j->queued >= j->config.max_queued)
        r = cv_error(CV_ERROR_LIMIT_EXCEEDED, "jobs: %u jobs wait already, the gateway's limit; try again later",
                     j->queued);
    else if (!make_room(j))
        r = cv_error(CV_ERROR_LIMIT_EXCEEDED, "jobs: the gateway keeps %u jobs and none has ended; try again later",
                     j->kept);
    if (r == CV_OK) {
        b->id = j->next_id++;
        job **tail = &j->table;
        while (*tail)
            tail = &(*tail)->next;
        *tail = b;
        job **q = &j->queue;
        while (*q)
            q = &(*q)->queue_next;
        *q = b;
        j->queued++;
        j->kept++;
        *id = b->id;
        pthread_cond_signal(&j->work);
    }
    pthread_mutex_unlock(&j->lock);
    if (r != CV_OK) {
        gw_store_release(j->config.store, scene);
        free(b);
    }
    return r;
}

/* With the lock held: the job as JSON. */
static cJSON *job_json(const job *b) {
    cJSON *o = cJSON_CreateObject();
    char link[96];
    bool ok = o && cJSON_AddNumberToObject(o, "id", (double)b->id) &&
              cJSON_AddStringToObject(o, "state", state_names[b->state]) &&
              cJSON_AddBoolToObject(o, "cancelling", b->cancel_requested && !ended(b)) &&
              cJSON_AddStringToObject(o, "scene", b->scene_sha) &&
              cJSON_AddNumberToObject(o, "width", b->settings.width) &&
              cJSON_AddNumberToObject(o, "height", b->settings.height) &&
              cJSON_AddNumberToObject(o, "frames", b->settings.frames) &&
              cJSON_AddNumberToObject(o, "frames_done", b->frames_done);
    if (ok && b->state == JOB_FAILED)
        ok = cJSON_AddStringToObject(o, "error", b->error) != NULL;
    if (ok && b->state == JOB_DONE) {
        snprintf(link, sizeof(link), "/api/v1/jobs/%llu/image.png", (unsigned long long)b->id);
        ok = cJSON_AddStringToObject(o, "png", link) != NULL;
        snprintf(link, sizeof(link), "/api/v1/jobs/%llu/image.exr", (unsigned long long)b->id);
        ok = ok && cJSON_AddStringToObject(o, "exr", link) != NULL;
    }
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

static cv_result no_job(uint64_t id) {
    return cv_error(CV_ERROR_NOT_FOUND, "job %llu: no such job (ended jobs are kept only while there is room)",
                    (unsigned long long)id);
}

cv_result gw_jobs_describe(gw_jobs *j, uint64_t id, cJSON **out) {
    pthread_mutex_lock(&j->lock);
    job *b = find(j, id);
    *out = b ? job_json(b) : NULL;
    pthread_mutex_unlock(&j->lock);
    return b ? CV_OK : no_job(id);
}

cJSON *gw_jobs_list(gw_jobs *j) {
    cJSON *o = cJSON_CreateObject();
    cJSON *list = o ? cJSON_AddArrayToObject(o, "jobs") : NULL;
    pthread_mutex_lock(&j->lock);
    for (job *b = j->table; list && b; b = b->next) {
        cJSON *item = job_json(b);
        if (!item || !cJSON_AddItemToArray(list, item)) {
            cJSON_Delete(item);
            list = NULL;
        }
    }
    pthread_mutex_unlock(&j->lock);
    if (!list) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

cv_result gw_jobs_cancel(gw_jobs *j, uint64_t id, cJSON **out) {
    pthread_mutex_lock(&j->lock);
    cv_result r = CV_OK;
    job *b = find(j, id);
    if (!b)
        r = no_job(id);
    else if (ended(b))
        r = cv_error(CV_ERROR_BAD_STATE, "job %llu has ended (%s): nothing to cancel", (unsigned long long)id,
                     state_names[b->state]);
    else if (b->cancel_requested)
        r = cv_error(CV_ERROR_BAD_STATE, "job %llu: a cancel is under way already", (unsigned long long)id);
    if (r == CV_OK) {
        b->cancel_requested = true;
        atomic_store(&b->cancel, true);
        if (b->state == JOB_QUEUED) {
            job **q = &j->queue;
            while (*q != b)
                q = &(*q)->queue_next;
            *q = b->queue_next;
            j->queued--;
            end_job(j, b, JOB_CANCELLED);
        }
        *out = job_json(b);
    }
    pthread_mutex_unlock(&j->lock);
    return r;
}

cv_result gw_jobs_image(gw_jobs *j, uint64_t id, bool exr, uint8_t **data, size_t *size) {
    pthread_mutex_lock(&j->lock);
    cv_result r = CV_OK;
    job *b = find(j, id);
    if (!b)
        r = no_job(id);
    else if (b->state != JOB_DONE)
        r = cv_error(CV_ERROR_BAD_STATE, "job %llu is %s: its image comes when it is done", (unsigned long long)id,
                     state_names[b->state]);
    if (r == CV_OK) {
        const uint8_t *bytes = exr ? b->images.exr : b->images.png;
        *size = exr ? b->images.exr_size : b->images.png_size;
        *data = malloc(*size);
        if (*data)
            memcpy(*data, bytes, *size);
        else
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "job %llu: a copy of its image", (unsigned long long)id);
    }
    pthread_mutex_unlock(&j->lock);
    return r;
}

cv_result gw_jobs_wait(gw_jobs *j, uint64_t id, uint32_t frames, uint32_t timeout_ms) {
    struct timespec deadline;
    clock_gettime(CLOCK_MONOTONIC, &deadline);
    deadline.tv_sec += timeout_ms / 1000;
    deadline.tv_nsec += (long)(timeout_ms % 1000) * 1000000L;
    if (deadline.tv_nsec >= 1000000000L) {
        deadline.tv_sec++;
        deadline.tv_nsec -= 1000000000L;
    }
    pthread_mutex_lock(&j->lock);
    cv_result r = CV_OK;
    for (;;) {
        job *b = find(j, id);
        if (!b) {
            r = no_job(id);
            break;
        }
        if (ended(b) || b->frames_done >= frames)
            break;
        if (pthread_cond_timedwait(&j->changed, &j->lock, &deadline) == ETIMEDOUT) {
            r = cv_error(CV_ERROR_TIMEOUT, "job %llu: still %s after %u ms (%u of %u frames)", (unsigned long long)id,
                         state_names[b->state], timeout_ms, b->frames_done, b->settings.frames);
            break;
        }
    }
    pthread_mutex_unlock(&j->lock);
    return r;
}
