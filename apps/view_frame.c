/* The frame header of corvid-view's WebSocket (view_frame.h). */
#include "view_frame.h"

#include <string.h>

static void put32(uint8_t *p, uint32_t v) {
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void put64(uint8_t *p, uint64_t v) {
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static void putf(uint8_t *p, double v) {
    float f = (float)v;
    uint32_t bits;
    memcpy(&bits, &f, 4);
    put32(p, bits);
}

void view_frame_header(uint8_t out[VIEW_FRAME_HEADER_BYTES], const cv_live_frame *f, uint64_t page_seq) {
    memset(out, 0, VIEW_FRAME_HEADER_BYTES);
    put32(out, VIEW_FRAME_MAGIC);
    out[4] = (uint8_t)f->codec;
    out[5] = f->keyframe ? 1 : 0;
    out[6] = VIEW_FRAME_HEADER_BYTES;
    put64(out + 8, f->index);
    put64(out + 16, page_seq);
    put32(out + 24, f->width);
    put32(out + 28, f->height);
    put32(out + 32, f->accumulated);
    putf(out + 36, f->input_age_ms);
    putf(out + 40, f->encode_ms);
}
