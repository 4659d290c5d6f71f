/* The binary frame message of corvid-view's WebSocket (docs/live-view.md): a fixed
 * little-endian header, then the encoded image. */
#ifndef CORVID_APPS_VIEW_FRAME_H
#define CORVID_APPS_VIEW_FRAME_H

#include <stddef.h>
#include <stdint.h>

#include "corvid/live.h"

#define VIEW_FRAME_MAGIC 0x31465643u /* "CVF1" */
#define VIEW_FRAME_HEADER_BYTES 48u

/* magic u32, codec u8, keyframe u8, header bytes u16, frame index u64, input seq u64 (the
 * page's), width u32, height u32, accumulated u32, server ms f32 (input to encoded),
 * encode ms f32, reserved u32. */
void view_frame_header(uint8_t out[VIEW_FRAME_HEADER_BYTES], const cv_live_frame *f, uint64_t page_seq);

#endif
