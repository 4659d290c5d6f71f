/* Encoder streams on the device's machine (device.h): the checks every backend
 * gets the same, the device's table of open streams, and the calls into the
 * backend's encoder ops: under the device lock, except the wait for a frame. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "device_internal.h"

bool cv_device_can_encode(cv_device *dev) { return dev && dev->backend->encoder_open; }

static encoder_stream *find_stream(cv_device *dev, uint32_t id) {
    for (uint32_t i = 0; i < dev->stream_count; i++)
        if (dev->streams[i].id == id)
            return &dev->streams[i];
    return NULL;
}

static cv_result unsupported(cv_device *dev, const char *what) {
    return cv_error(CV_ERROR_UNSUPPORTED, "device '%s': %s: the %s backend has no encoder streams", dev->label, what,
                    dev->backend->name);
}

cv_result cv_device_encoder_open(cv_device *dev, cv_codec codec, uint32_t width, uint32_t height, uint32_t *stream) {
    if (!dev || !stream)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "encoder open: NULL argument");
    if (!cv_device_can_encode(dev))
        return unsupported(dev, "encoder open");
    cv_result r = cv_encode_check_stream(codec, width, height, "encoder open");
    if (r != CV_OK)
        return r;
    pthread_mutex_lock(&dev->lock);
    if (dev->stream_count == dev->stream_capacity) {
        uint32_t cap = dev->stream_capacity ? dev->stream_capacity * 2 : 4;
        encoder_stream *s = realloc(dev->streams, cap * sizeof(*s));
        if (s) {
            dev->streams = s;
            dev->stream_capacity = cap;
        } else {
            r = cv_error(CV_ERROR_OUT_OF_MEMORY, "device '%s': encoder open", dev->label);
        }
    }
    uint32_t id = dev->last_stream + 1;
    while (r == CV_OK && (id == 0 || find_stream(dev, id))) /* after 2^32 opens, skip the live ones */
        id++;
    if (r == CV_OK)
        r = dev->backend->encoder_open(dev->bd, id, codec, width, height);
    if (r == CV_OK) {
        dev->streams[dev->stream_count++] = (encoder_stream){ id, codec, width, height };
        dev->last_stream = id;
        *stream = id;
    }
    pthread_mutex_unlock(&dev->lock);
    return r;
}

/* The stream, texture and rect of a read, checked (lock held). */
static cv_result check_read(cv_device *dev, uint32_t stream, cv_texture t, cv_rect rect,
                            const cv_encode_params *params, cv_device_resource **out, cv_codec *codec) {
    const encoder_stream *st = find_stream(dev, stream);
    if (!st)
        return cv_error(CV_ERROR_INVALID_HANDLE, "device '%s': encoder read: stream %u is not open", dev->label,
                        stream);
    *codec = st->codec;
    cv_result r = cv_device_require(dev, t.id, CV_HANDLE_TEXTURE, "encoder read", out);
    if (r != CV_OK)
        return r;
    const cv_texture_desc *d = &(*out)->desc.texture;
    if (rect.x > d->width || rect.width > d->width - rect.x || rect.y > d->height || rect.height > d->height - rect.y)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "texture '%s' (%ux%u): encoder read of %ux%u at (%u,%u) is out of range", d->label, d->width,
                        d->height, rect.width, rect.height, rect.x, rect.y);
    if (rect.width != st->width || rect.height != st->height)
        return cv_error(CV_ERROR_FORMAT_MISMATCH,
                        "texture '%s': encoder read of %ux%u into stream %u, whose frames are %ux%u", d->label,
                        rect.width, rect.height, stream, st->width, st->height);
    char what[CV_LABEL_MAX + 32];
    snprintf(what, sizeof(what), "texture '%s': encoder read", d->label);
    r = cv_encode_check_format(st->codec, d->format, what);
    return r == CV_OK ? cv_encode_check_params(params, what) : r;
}

cv_result cv_device_encoder_read(cv_device *dev, uint32_t stream, cv_texture t, cv_rect rect,
                                 const cv_encode_params *params, cv_encoded *out) {
    if (!dev || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "encoder read: NULL argument");
    memset(out, 0, sizeof(*out));
    if (!cv_device_can_encode(dev))
        return unsupported(dev, "encoder read");
    pthread_mutex_lock(&dev->lock);
    cv_device_resource *s = NULL;
    cv_codec codec = CV_CODEC_COUNT;
    cv_result r = check_read(dev, stream, t, rect, params, &s, &codec);
    if (r == CV_OK)
        r = cv_device_wait_for_resource(dev, s);
    if (r == CV_OK)
        r = dev->backend->encoder_send(dev->bd, stream, s->obj, &s->desc.texture, rect, params);
    pthread_mutex_unlock(&dev->lock);
    if (r == CV_OK) /* the device's machine reads and encodes while other calls go on */
        r = dev->backend->encoder_receive(dev->bd, stream, out);
    if (r == CV_OK && (out->width != rect.width || out->height != rect.height || out->codec != codec))
        r = cv_error(CV_ERROR_MALFORMED, "device '%s': stream %u: a %ux%u frame of codec %u came for a %ux%u %s read",
                     dev->label, stream, out->width, out->height, (unsigned)out->codec, rect.width, rect.height,
                     cv_codec_name(codec));
    if (r != CV_OK)
        cv_encoded_free(out);
    return r;
}

void cv_device_encoder_close(cv_device *dev, uint32_t stream) {
    if (!dev || !cv_device_can_encode(dev))
        return;
    pthread_mutex_lock(&dev->lock);
    encoder_stream *st = find_stream(dev, stream);
    if (st) {
        dev->backend->encoder_close(dev->bd, stream);
        *st = dev->streams[--dev->stream_count];
    }
    pthread_mutex_unlock(&dev->lock);
}

void cv_device_close_encoders(cv_device *dev) {
    for (uint32_t i = 0; i < dev->stream_count; i++)
        dev->backend->encoder_close(dev->bd, dev->streams[i].id);
    dev->stream_count = 0;
    free(dev->streams);
    dev->streams = NULL;
    dev->stream_capacity = 0;
}
