/* Frame readers: a texture of a device, read already encoded on the device's
 * machine. For a proxy device the node reads and encodes (its session holds the
 * encoder: device.h's encoder streams), so only the encoded bytes cross the
 * link; for a local device the reader reads the texels here (one host buffer,
 * reused) and encodes them with frame_codec.h. Either way *out says how long the
 * read and the encode took, where they ran.
 *
 *     cv_frame_reader *r;
 *     if (cv_frame_reader_create(dev, CV_CODEC_JPEG, 640, 360, &r) == CV_OK) {
 *         cv_encode_params p = { .quality = 80 };
 *         cv_encoded frame = { 0 };
 *         if (cv_frame_reader_read(r, display, (cv_rect){ 0, 0, 640, 360 }, &p, &frame) == CV_OK)
 *             send(sock, frame.data, frame.size);   // a JPEG, a few tens of kB
 *         cv_encoded_free(&frame);
 *         cv_frame_reader_destroy(r);
 *     }
 *
 * The checks are the same for every device (device.h, encode_types.h): the
 * codec and size (H.264 even), the texture loaded on the device with the
 * format the codec takes, rect inside it with the reader's size, and the
 * parameters. A refused read changes nothing; the reader and the device go on.
 * One reader is one stream (an H.264 one keeps its state from frame to frame):
 * one thread at a time; other calls on the device may run meanwhile. */
#ifndef CORVID_FRAME_READER_H
#define CORVID_FRAME_READER_H

#include "corvid/device.h"
#include "corvid/encode_types.h"

typedef struct cv_frame_reader cv_frame_reader;

cv_result cv_frame_reader_create(cv_device *dev, cv_codec codec, uint32_t width, uint32_t height,
                                 cv_frame_reader **out);
/* texture: RGBA8_UNORM for JPEG/H264/PNG, any format for ZSTD/RAW; rect's size must be
 * the reader's width x height. Waits for submitted work that writes the texture (as
 * cv_device_read_texture). Thread-safe with other calls on the device. */
cv_result cv_frame_reader_read(cv_frame_reader *r, cv_texture t, cv_rect rect, const cv_encode_params *params,
                               cv_encoded *out);
void cv_frame_reader_destroy(cv_frame_reader *r); /* NULL is ignored */

/* Whether r encodes on the device's machine (a remote encoder stream) rather than here. */
bool cv_frame_reader_is_remote(const cv_frame_reader *r);

#endif
