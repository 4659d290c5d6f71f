/* H.264 decoding through openh264 (for tests, tools and benchmarks): one access unit per
 * call, decoded without delay (baseline has no reordering) to I420, then RGBA8. Error
 * concealment is off: a damaged or hostile stream gives an error, never a guessed picture. */
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <wels/codec_api.h>

#include "corvid/frame_codec.h"
#include "h264_codec.h"
#include "rgb_yuv.h"

typedef struct h264_decoder {
    ISVCDecoder *wels;
    h264_trace trace;
} h264_decoder;

void h264_decoder_destroy(void *state) {
    h264_decoder *d = state;
    if (d->wels) {
        (*d->wels)->Uninitialize(d->wels);
        WelsDestroyDecoder(d->wels);
    }
    free(d);
}

cv_result h264_decoder_create(void **state) {
    h264_decoder *d = calloc(1, sizeof *d);
    if (!d)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "h264 decoder: no memory");
    d->trace.origin = "h264 decoder";
    if (WelsCreateDecoder(&d->wels) != 0 || !d->wels) {
        d->wels = NULL;
        h264_decoder_destroy(d);
        return cv_error(CV_ERROR_BACKEND, "h264 decoder: openh264 made no decoder");
    }
    WelsTraceCallback trace = h264_trace_message;
    void *trace_context = &d->trace;
    (*d->wels)->SetOption(d->wels, DECODER_OPTION_TRACE_CALLBACK_CONTEXT, &trace_context);
    (*d->wels)->SetOption(d->wels, DECODER_OPTION_TRACE_CALLBACK, &trace);
    SDecodingParam param;
    memset(&param, 0, sizeof param);
    param.uiTargetDqLayer = UCHAR_MAX;
    param.eEcActiveIdc = ERROR_CON_DISABLE;
    param.sVideoProperty.size = sizeof param.sVideoProperty;
    param.sVideoProperty.eVideoBsType = VIDEO_BITSTREAM_AVC;
    if ((*d->wels)->Initialize(d->wels, &param) != 0) {
        h264_decoder_destroy(d);
        return cv_error(CV_ERROR_BACKEND, "h264 decoder: openh264 refused its parameters");
    }
    *state = d;
    return CV_OK;
}

cv_result h264_decode(void *state, const uint8_t *data, size_t size, uint8_t **out, size_t *out_size, uint32_t *width,
                      uint32_t *height) {
    h264_decoder *d = state;
    if (size == 0 || size > INT_MAX)
        return cv_error(CV_ERROR_MALFORMED, "h264 decoder: an access unit of %zu bytes", size);
    unsigned char *planes[3] = { NULL, NULL, NULL };
    SBufferInfo info;
    memset(&info, 0, sizeof info);
    d->trace.last[0] = '\0';
    DECODING_STATE state_bits = (*d->wels)->DecodeFrameNoDelay(d->wels, data, (int)size, planes, &info);
    if (state_bits != dsErrorFree)
        return cv_error(CV_ERROR_MALFORMED, "h264 decoder: a %zu-byte access unit does not decode (state 0x%x): %s",
                        size, (unsigned)state_bits, d->trace.last);
    if (info.iBufferStatus != 1)
        return CV_OK; /* no picture yet: parameter sets alone, say */
    const SSysMEMBuffer *pic = &info.UsrData.sSystemBuffer;
    if (pic->iWidth <= 0 || pic->iHeight <= 0 || (uint32_t)pic->iWidth > CV_CODEC_MAX_SIDE ||
        (uint32_t)pic->iHeight > CV_CODEC_MAX_SIDE || !planes[0] || !planes[1] || !planes[2])
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "h264 decoder: a %dx%d picture, outside 1..%u a side", pic->iWidth,
                        pic->iHeight, CV_CODEC_MAX_SIDE);
    uint32_t w = (uint32_t)pic->iWidth, h = (uint32_t)pic->iHeight;
    size_t n = (size_t)w * h * 4u;
    uint8_t *rgba = malloc(n);
    if (!rgba)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "h264 decoder: no memory for %ux%u pixels", w, h);
    yuv_planes_const yuv = { planes[0], planes[1], planes[2], (size_t)pic->iStride[0], (size_t)pic->iStride[1] };
    i420_to_rgba(&yuv, w, h, rgba, (size_t)w * 4u);
    *out = rgba;
    *out_size = n;
    *width = w;
    *height = h;
    return CV_OK;
}
