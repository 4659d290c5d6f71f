/* cv_live_snapshot: a lossless copy of the newest frame, read through a
 * frame reader of its own (on a proxy device the node encodes it) while the
 * render thread holds still, so the step's display and radiance stay as they
 * are until the read is done. */
#include "corvid/clock.h"
#include "corvid/frame_reader.h"
#include "live_internal.h"

/* The longest a snapshot waits for a step to finish. */
#define LIVE_SNAPSHOT_WAIT_MS 10000u

/* Holds the render thread and waits for a finished step with none in
 * progress (lock held); the step into *out. */
static cv_result hold_newest(cv_live *l, cv_render_step *out) {
    uint64_t deadline = cv_deadline_after_ms(LIVE_SNAPSHOT_WAIT_MS);
    while (!l->failed && !l->stopping && (l->stepping || !l->published.step) &&
           cv_cond_wait_until(&l->snapshot_cond, &l->lock, deadline) == 0) {
    }
    if (l->failed)
        return cv_error(CV_ERROR_BAD_STATE, "live: snapshot: the live has stopped after an error: %s", l->error);
    if (l->stopping)
        return cv_error(CV_ERROR_BAD_STATE, "live: snapshot: the live is stopping");
    if (l->stepping || !l->published.step)
        return cv_error(CV_ERROR_TIMEOUT, "live: snapshot: no frame finished within %u ms", LIVE_SNAPSHOT_WAIT_MS);
    *out = l->published.info;
    return CV_OK;
}

cv_result cv_live_snapshot(cv_live *l, cv_codec codec, cv_encoded *out) {
    if (!l || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "live: snapshot: NULL %s", l ? "out" : "live");
    if (codec != CV_CODEC_PNG && codec != CV_CODEC_ZSTD)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "live: snapshot: codec %s is not lossless (png: the display, zstd: the radiance)",
                        cv_codec_name(codec));
    pthread_mutex_lock(&l->lock);
    l->hold++;
    cv_render_step step = { 0 };
    cv_result res = hold_newest(l, &step);
    pthread_mutex_unlock(&l->lock);
    cv_frame_reader *reader = NULL;
    cv_encoded e = { 0 };
    if (res == CV_OK)
        res = cv_frame_reader_create(l->desc.primary, codec, step.width, step.height, &reader);
    if (res == CV_OK) {
        cv_texture t = codec == CV_CODEC_PNG ? step.display : step.radiance;
        res = cv_frame_reader_read(reader, t, (cv_rect){ 0, 0, step.width, step.height }, &(cv_encode_params){ 0 },
                                   &e);
    }
    cv_frame_reader_destroy(reader);
    pthread_mutex_lock(&l->lock);
    l->hold--;
    pthread_cond_broadcast(&l->render_cond);
    pthread_mutex_unlock(&l->lock);
    if (res != CV_OK)
        return res;
    e.width = step.width;
    e.height = step.height;
    *out = e;
    return CV_OK;
}
