/* The gateway's jobs: a table of jobs by id, a bounded queue and a small
 * pool of worker threads that render them (job_render.h) on devices opened
 * per job by the program's callback. A job goes queued -> running -> done,
 * failed (with the error) or cancelled; a cancel is seen between frames. The
 * table keeps at most max_jobs (the oldest ended ones make room). Thread-safe. */
#ifndef CORVID_GATEWAY_JOBS_H
#define CORVID_GATEWAY_JOBS_H

#include <cjson/cJSON.h>
#include <stdbool.h>

#include "corvid/gateway_types.h"
#include "corvid/log.h"
#include "job_request.h"
#include "scene_store.h"

typedef struct gw_jobs gw_jobs;

typedef struct gw_jobs_config {
    cv_gateway_open_devices_fn open_devices;
    void *user;
    uint32_t workers, max_queued, max_jobs;
    const char *temp_dir;
    gw_store *store; /* the scene references jobs hold are released to it */
    cv_log_fn log;   /* NULL = cv_log */
    void *log_user;
} gw_jobs_config;

cv_result gw_jobs_create(const gw_jobs_config *config, gw_jobs **out);
/* Cancels every job, joins the workers, frees the jobs. */
void gw_jobs_destroy(gw_jobs *j);

/* Queues a job on `scene` (a reference the job takes over, released even on failure; NULL for the built-in
 * room). CV_ERROR_LIMIT_EXCEEDED when max_queued jobs wait or max_jobs are kept and none has ended (the
 * caller answers 429). */
cv_result gw_jobs_submit(gw_jobs *j, const gw_job_request *req, const gw_scene *scene, uint64_t *id);

/* A job as JSON (*out; NULL only when out of memory): CV_ERROR_NOT_FOUND for no such job. */
cv_result gw_jobs_describe(gw_jobs *j, uint64_t id, cJSON **out);
/* Every job kept, oldest first: {"jobs": [...]}. */
cJSON *gw_jobs_list(gw_jobs *j);
/* Cancels a queued or running job and describes it: CV_ERROR_BAD_STATE when it has ended or a cancel is
 * under way already, CV_ERROR_NOT_FOUND for no such job. */
cv_result gw_jobs_cancel(gw_jobs *j, uint64_t id, cJSON **out);
/* A copy of a done job's PNG (or EXR): CV_ERROR_BAD_STATE until it is done. */
cv_result gw_jobs_image(gw_jobs *j, uint64_t id, bool exr, uint8_t **data, size_t *size);
/* As cv_gateway_wait_job. */
cv_result gw_jobs_wait(gw_jobs *j, uint64_t id, uint32_t frames, uint32_t timeout_ms);

#endif
