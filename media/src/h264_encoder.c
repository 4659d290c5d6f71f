/* H.264 encoding through openh264: RGBA8 converted to I420 (rgb_yuv.c), then one
 * constrained-baseline picture per frame, rate-controlled on the bitrate, as Annex B NAL
 * units: one slice, or from 1280x720 on H264_SLICES slices encoded on as many threads. The
 * first frame and every requested one are IDR pictures, each preceded by the SPS and PPS, so
 * a viewer can start from any of them. Bitrate and frame rate follow the params of each call. */
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <wels/codec_api.h>

#include "codec_ops.h"
#include "corvid/frame_codec.h"
#include "h264_codec.h"
#include "rgb_yuv.h"

/* Encoder effort: LOW_COMPLEXITY is openh264's fastest mode; docs/media.md has its cost and
 * quality against MEDIUM at 1080p. */
#define H264_COMPLEXITY LOW_COMPLEXITY
/* openh264 spreads a picture over threads by slices only. From this many pixels on (720p), a
 * picture is cut into H264_SLICES slices on as many threads: at 1080p that took the encode
 * from 32 to 21 ms (wall) for 7% more CPU and 0.2 dB (docs/media.md); smaller pictures keep
 * one slice, a thread's handoff would cost more than it saves. */
#define H264_SLICED_PIXELS (1280u * 720u)
#define H264_SLICES 4
/* The most openh264 takes (its MAX_BIT_RATE: level 5.2's 240 Mbit/s x 1.2); it refuses more, so a
 * higher request (encode_types.h allows up to 1 Gbit/s) is served at this. */
#define H264_MAX_BITRATE_KBPS 288000u

typedef struct h264_encoder {
    ISVCEncoder *wels;
    uint32_t width, height;
    uint8_t *yuv;               /* I420: Y, then U, then V */
    uint32_t bitrate_kbps, fps; /* as configured */
    uint64_t frames;
    h264_trace trace;
} h264_encoder;

void h264_encoder_destroy(void *state) {
    h264_encoder *e = state;
    if (e->wels) {
        (*e->wels)->Uninitialize(e->wels);
        WelsDestroySVCEncoder(e->wels);
    }
    free(e->yuv);
    free(e);
}

static void describe(const h264_encoder *e, uint32_t bitrate_kbps, uint32_t fps, SEncParamExt *p) {
    (*e->wels)->GetDefaultParams(e->wels, p);
    p->iUsageType = CAMERA_VIDEO_REAL_TIME;
    p->iPicWidth = (int)e->width;
    p->iPicHeight = (int)e->height;
    p->iTargetBitrate = (int)(bitrate_kbps * 1000u);
    p->iMaxBitrate = UNSPECIFIED_BIT_RATE;
    p->iRCMode = RC_BITRATE_MODE;
    p->fMaxFrameRate = (float)fps;
    p->iTemporalLayerNum = 1;
    p->iSpatialLayerNum = 1;
    p->iComplexityMode = H264_COMPLEXITY;
    p->uiIntraPeriod = 0; /* IDR only on the first frame and on request */
    p->iNumRefFrame = 1;
    p->eSpsPpsIdStrategy = CONSTANT_ID;
    p->bPrefixNalAddingCtrl = false;
    p->iEntropyCodingModeFlag = 0; /* CAVLC: baseline */
    p->bEnableFrameSkip = false;   /* every call gives a picture; a skipped frame would look like a stall */
    bool sliced = (uint64_t)e->width * e->height >= H264_SLICED_PIXELS;
    p->iMultipleThreadIdc = sliced ? H264_SLICES : 1;
    p->bEnableDenoise = false;
    p->bEnableBackgroundDetection = false;
    p->bEnableSceneChangeDetect = false; /* a keyframe only when the caller asks */
    p->bEnableLongTermReference = false;
    SSpatialLayerConfig *layer = &p->sSpatialLayers[0];
    layer->iVideoWidth = (int)e->width;
    layer->iVideoHeight = (int)e->height;
    layer->fFrameRate = (float)fps;
    layer->iSpatialBitrate = p->iTargetBitrate;
    layer->iMaxSpatialBitrate = UNSPECIFIED_BIT_RATE;
    layer->uiProfileIdc = PRO_BASELINE;
    layer->sSliceArgument.uiSliceMode = sliced ? SM_FIXEDSLCNUM_SLICE : SM_SINGLE_SLICE;
    layer->sSliceArgument.uiSliceNum = sliced ? H264_SLICES : 1;
}

cv_result h264_encoder_create(uint32_t width, uint32_t height, void **state) {
    h264_encoder *e = calloc(1, sizeof *e);
    size_t luma = (size_t)width * height;
    if (!e || !(e->yuv = malloc(luma + luma / 2))) {
        free(e);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "h264 encoder %ux%u: no memory", width, height);
    }
    e->width = width;
    e->height = height;
    e->trace.origin = "h264 encoder";
    if (WelsCreateSVCEncoder(&e->wels) != 0 || !e->wels) {
        e->wels = NULL;
        h264_encoder_destroy(e);
        return cv_error(CV_ERROR_BACKEND, "h264 encoder %ux%u: openh264 made no encoder", width, height);
    }
    WelsTraceCallback trace = h264_trace_message;
    void *trace_context = &e->trace;
    (*e->wels)->SetOption(e->wels, ENCODER_OPTION_TRACE_CALLBACK_CONTEXT, &trace_context);
    (*e->wels)->SetOption(e->wels, ENCODER_OPTION_TRACE_CALLBACK, &trace);
    *state = e;
    return CV_OK;
}

/* Starts the stream on the first frame; afterwards applies a new bitrate or frame rate. */
static cv_result configure(h264_encoder *e, const cv_encode_params *params) {
    cv_encode_params capped = *params;
    if (capped.bitrate_kbps > H264_MAX_BITRATE_KBPS)
        capped.bitrate_kbps = H264_MAX_BITRATE_KBPS;
    const cv_encode_params *p = &capped;
    int rc = 0;
    if (e->frames == 0) {
        SEncParamExt param;
        describe(e, p->bitrate_kbps, p->fps, &param);
        rc = (*e->wels)->InitializeExt(e->wels, &param);
        int format = videoFormatI420;
        if (rc == 0)
            rc = (*e->wels)->SetOption(e->wels, ENCODER_OPTION_DATAFORMAT, &format);
    } else {
        if (rc == 0 && p->fps != e->fps) {
            float fps = (float)p->fps;
            rc = (*e->wels)->SetOption(e->wels, ENCODER_OPTION_FRAME_RATE, &fps);
        }
        if (rc == 0 && p->bitrate_kbps != e->bitrate_kbps) {
            SBitrateInfo bitrate = { .iLayer = SPATIAL_LAYER_ALL, .iBitrate = (int)(p->bitrate_kbps * 1000u) };
            rc = (*e->wels)->SetOption(e->wels, ENCODER_OPTION_BITRATE, &bitrate);
        }
    }
    if (rc != 0)
        return cv_error(CV_ERROR_BACKEND, "h264 encoder %ux%u: openh264 refused %u kbit/s at %u fps (%d): %s",
                        e->width, e->height, p->bitrate_kbps, p->fps, rc, e->trace.last);
    e->bitrate_kbps = p->bitrate_kbps;
    e->fps = p->fps;
    return CV_OK;
}

/* The frame's NAL units, start codes included, in one malloc'd buffer. */
static cv_result collect(const h264_encoder *e, const SFrameBSInfo *info, cv_encoded *out) {
    size_t size = 0;
    for (int l = 0; l < info->iLayerNum; l++)
        for (int n = 0; n < info->sLayerInfo[l].iNalCount; n++)
            size += (size_t)info->sLayerInfo[l].pNalLengthInByte[n];
    if (size == 0)
        return cv_error(CV_ERROR_BACKEND, "h264 encoder %ux%u: openh264 gave no picture (frame type %d)", e->width,
                        e->height, (int)info->eFrameType);
    uint8_t *data = malloc(size);
    if (!data)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "h264 encoder: no memory for %zu bytes", size);
    size_t at = 0;
    for (int l = 0; l < info->iLayerNum; l++) {
        const SLayerBSInfo *layer = &info->sLayerInfo[l];
        size_t bytes = 0;
        for (int n = 0; n < layer->iNalCount; n++)
            bytes += (size_t)layer->pNalLengthInByte[n];
        memcpy(data + at, layer->pBsBuf, bytes); /* a layer's NAL units lie back to back */
        at += bytes;
    }
    out->data = data;
    out->size = size;
    out->keyframe = info->eFrameType == videoFrameTypeIDR;
    return CV_OK;
}

cv_result h264_encode(void *state, const uint8_t *pixels, size_t stride, const cv_encode_params *params,
                      cv_encoded *out) {
    h264_encoder *e = state;
    cv_result r = configure(e, params);
    if (r != CV_OK)
        return r;
    size_t luma = (size_t)e->width * e->height;
    yuv_planes planes = { e->yuv, e->yuv + luma, e->yuv + luma + luma / 4, e->width, e->width / 2 };
    rgba_to_i420(pixels, stride, e->width, e->height, &planes);
    SSourcePicture pic = {
        .iColorFormat = videoFormatI420,
        .iStride = { (int)planes.y_stride, (int)planes.uv_stride, (int)planes.uv_stride },
        .pData = { planes.y, planes.u, planes.v },
        .iPicWidth = (int)e->width,
        .iPicHeight = (int)e->height,
        .uiTimeStamp = (long long)(e->frames * 1000u / e->fps),
    };
    if (params->keyframe && e->frames > 0)
        (*e->wels)->ForceIntraFrame(e->wels, true);
    SFrameBSInfo info;
    memset(&info, 0, sizeof info);
    int rc = (*e->wels)->EncodeFrame(e->wels, &pic, &info);
    if (rc != 0)
        return cv_error(CV_ERROR_BACKEND, "h264 encoder %ux%u: frame %llu: openh264 failed (%d): %s", e->width,
                        e->height, (unsigned long long)e->frames, rc, e->trace.last);
    r = collect(e, &info, out);
    if (r == CV_OK)
        e->frames++;
    return r;
}
