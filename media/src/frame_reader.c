/* Frame readers (frame_reader.h): a remote encoder stream for devices that have
 * them (device.h), else a read into a reused host buffer and an encoder here. */
#include "corvid/frame_reader.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/clock.h"
#include "corvid/frame_codec.h"

struct cv_frame_reader {
    cv_device *dev;
    cv_codec codec;
    uint32_t width, height;
    uint32_t stream;     /* remote: the device's encoder stream (0: local) */
    cv_encoder *encoder; /* local */
    uint8_t *pixels;     /* local: the texels read, kept for the next frame */
    size_t capacity;
};

cv_result cv_frame_reader_create(cv_device *dev, cv_codec codec, uint32_t width, uint32_t height,
                                 cv_frame_reader **out) {
    if (!dev || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "frame reader: NULL argument");
    cv_result r = cv_encode_check_stream(codec, width, height, "frame reader");
    if (r != CV_OK)
        return r;
    cv_frame_reader *fr = calloc(1, sizeof(*fr));
    if (!fr)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "frame reader");
    *fr = (cv_frame_reader){ .dev = dev, .codec = codec, .width = width, .height = height };
    r = cv_device_can_encode(dev) ? cv_device_encoder_open(dev, codec, width, height, &fr->stream)
                                  : cv_encoder_create(codec, width, height, &fr->encoder);
    if (r != CV_OK) {
        free(fr);
        return r;
    }
    *out = fr;
    return CV_OK;
}

bool cv_frame_reader_is_remote(const cv_frame_reader *r) { return r && r->stream != 0; }

/* The checks device.h gives an encoder stream's read, in the same order, so a
 * local reader refuses what a remote one does, with the same code. */
static cv_result check_local(cv_frame_reader *r, cv_texture t, cv_rect rect, const cv_encode_params *params,
                             cv_format *format) {
    cv_resource_desc desc;
    cv_result rr = cv_context_describe(cv_device_context(r->dev), (cv_handle){ t.id }, &desc);
    if (rr != CV_OK)
        return rr;
    if (desc.type != CV_HANDLE_TEXTURE)
        return cv_error(CV_ERROR_WRONG_HANDLE_TYPE, "frame reader: needs a texture, got a %s",
                        cv_handle_type_name(desc.type));
    const cv_texture_desc *d = &desc.texture;
    if (rect.x > d->width || rect.width > d->width - rect.x || rect.y > d->height || rect.height > d->height - rect.y)
        return cv_error(CV_ERROR_OUT_OF_RANGE,
                        "texture '%s' (%ux%u): encoder read of %ux%u at (%u,%u) is out of range", d->label, d->width,
                        d->height, rect.width, rect.height, rect.x, rect.y);
    if (rect.width != r->width || rect.height != r->height)
        return cv_error(CV_ERROR_FORMAT_MISMATCH,
                        "texture '%s': encoder read of %ux%u into a frame reader whose frames are %ux%u", d->label,
                        rect.width, rect.height, r->width, r->height);
    char what[CV_LABEL_MAX + 32];
    snprintf(what, sizeof(what), "texture '%s': encoder read", d->label);
    rr = cv_encode_check_format(r->codec, d->format, what);
    if (rr == CV_OK)
        rr = cv_encode_check_params(params, what);
    *format = d->format;
    return rr;
}

static cv_result read_local(cv_frame_reader *r, cv_texture t, cv_rect rect, const cv_encode_params *params,
                            cv_encoded *out) {
    cv_format format = CV_FORMAT_UNDEFINED;
    cv_result rr = check_local(r, t, rect, params, &format);
    if (rr != CV_OK)
        return rr;
    size_t row = (size_t)r->width * cv_format_bytes(format);
    size_t bytes = row * r->height;
    if (bytes > r->capacity) {
        uint8_t *p = realloc(r->pixels, bytes);
        if (!p)
            return cv_error(CV_ERROR_OUT_OF_MEMORY, "frame reader: %zu bytes of texels", bytes);
        r->pixels = p;
        r->capacity = bytes;
    }
    double start = cv_now_ms();
    rr = cv_device_read_texture(r->dev, t, rect, r->pixels);
    double read_ms = cv_now_ms() - start;
    if (rr == CV_OK)
        rr = cv_encoder_encode(r->encoder, r->pixels, row, params, out);
    if (rr == CV_OK)
        out->read_ms = read_ms;
    return rr;
}

cv_result cv_frame_reader_read(cv_frame_reader *r, cv_texture t, cv_rect rect, const cv_encode_params *params,
                               cv_encoded *out) {
    if (!r || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "frame reader read: NULL argument");
    memset(out, 0, sizeof(*out));
    cv_result rr = r->stream ? cv_device_encoder_read(r->dev, r->stream, t, rect, params, out)
                             : read_local(r, t, rect, params, out);
    if (rr != CV_OK)
        cv_encoded_free(out);
    return rr;
}

void cv_frame_reader_destroy(cv_frame_reader *r) {
    if (!r)
        return;
    if (r->stream)
        cv_device_encoder_close(r->dev, r->stream);
    cv_encoder_destroy(r->encoder);
    free(r->pixels);
    free(r);
}
