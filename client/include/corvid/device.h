/* Devices: one logical GPU each, behind a backend.
 *
 * A device is created from a backend (vulkan, mock, proxy, ...) and attached to
 * a context. It keeps its own representation of each handle it has loaded,
 * compiles command lists for itself (once per list version) and submits them.
 * Any number of devices, of any backends, can live in one process; devices can
 * be created and destroyed while the application runs.
 *
 * Before a list is compiled, it is validated against this device's resources
 * (client/src/validate.c): every handle loaded and of the right type, every copy and
 * binding in bounds, formats and usages matching the pipeline registry. A bad
 * list is rejected with a message and nothing is submitted.
 *
 * Thread-safe: each call locks the device; different devices run in parallel. */
#ifndef CORVID_DEVICE_H
#define CORVID_DEVICE_H

#include "corvid/context.h"
#include "corvid/device_info.h"
#include "corvid/encode_types.h"

cv_result cv_device_create(cv_context *ctx, const cv_backend *backend, const cv_device_desc *desc, cv_device **out);
/* Waits for the device's work, releases everything it holds, detaches it. */
void cv_device_destroy(cv_device *dev);
const cv_device_info *cv_device_get_info(const cv_device *dev);
const char *cv_device_label(const cv_device *dev);
cv_context *cv_device_context(const cv_device *dev);

/* Creates this device's representation of a buffer/texture/sampler/pipeline. */
cv_result cv_device_load(cv_device *dev, cv_handle h);
/* Zero-copy between devices of one adapter: loads texture h on `dev` as an
 * alias of its representation on `owner`, so both read and write one memory.
 * h must be loaded on `owner` with CV_TEXTURE_USAGE_SHARED and not on `dev`;
 * the two devices must be different instances of one adapter and driver
 * whose backend can share memory (Vulkan: VK_KHR_external_memory_fd, equal
 * driver and device UUIDs). Load the alias before writing the texture: what
 * it held before is undefined afterwards. Neither side orders its work after
 * the other's by itself: the caller does (cv_device_gpu_wait), and two
 * devices may write at once only texels the other does not touch. Unloading
 * either side leaves the other's memory alive. CV_ERROR_UNSUPPORTED naming
 * what is missing when the pair cannot alias; nothing changes then. */
cv_result cv_device_load_alias(cv_device *dev, cv_handle h, cv_device *owner);
/* Whether h is loaded on dev as an alias (cv_device_load_alias). */
bool cv_device_is_alias(cv_device *dev, cv_handle h);
/* Whether cv_device_load_alias can work between the two devices (false: why,
 * in `why`). */
bool cv_device_can_alias(cv_device *dev, cv_device *owner, char *why, size_t why_size);
/* A GPU-side wait: work submitted to `dev` after this call runs after `other`
 * (same backend) reached `other_ticket` on the GPU, with the other's writes
 * visible; the host does not wait. *ticket is the wait's own ticket on dev.
 * An `other_ticket` already reached costs a ticket and no wait. */
cv_result cv_device_gpu_wait(cv_device *dev, cv_device *other, uint64_t other_ticket, uint64_t *ticket);
/* Drops it (released once submitted work using it has finished). */
cv_result cv_device_unload(cv_device *dev, cv_handle h);
/* Whether the device holds a representation of exactly this handle (a compiled
 * form, for command lists). */
bool cv_device_has(cv_device *dev, cv_handle h);
/* Number of representations loaded (all types), for leak checks. */
uint32_t cv_device_loaded_count(cv_device *dev);

/* Host <-> device data. Writes wait for submitted work that uses the resource;
 * reads wait for it to finish, so they see its results. Texture data is tightly
 * packed rows of rect.width texels. */
cv_result cv_device_write_buffer(cv_device *dev, cv_buffer b, uint64_t offset, uint64_t size, const void *data);
cv_result cv_device_read_buffer(cv_device *dev, cv_buffer b, uint64_t offset, uint64_t size, void *out);
cv_result cv_device_write_texture(cv_device *dev, cv_texture t, cv_rect rect, const void *data);
cv_result cv_device_read_texture(cv_device *dev, cv_texture t, cv_rect rect, void *out);

/* Builds the device's acceleration structure from a flat BVH (see
 * cv_accel_desc for the layout); sizes come from the accel's description.
 * Until this succeeds, trace_rays on the accel is rejected. */
cv_result cv_device_write_accel(cv_device *dev, cv_accel accel, const void *nodes, const void *triangles);

/* Validates and compiles a list for this device (submit does this on demand). */
cv_result cv_device_compile(cv_device *dev, cv_cmdlist list);
/* Submits a compiled (or compilable) list; *ticket identifies this submission. */
cv_result cv_device_submit(cv_device *dev, cv_cmdlist list, uint64_t *ticket);
/* Waits for a submission; timeout_ns = UINT64_MAX waits forever. A submission
 * up to `ticket` that ran but had a command refused by the device (a
 * dispatch_indirect whose group counts, read from its buffer when it ran,
 * exceed max_dispatch: it dispatches nothing) makes the first wait covering it
 * return CV_ERROR_OUT_OF_RANGE naming the command; the rest of it ran. */
cv_result cv_device_wait(cv_device *dev, uint64_t ticket, uint64_t timeout_ns);
cv_result cv_device_wait_idle(cv_device *dev);
/* Pass timings of a finished submission (the latest submission of its list). */
cv_result cv_device_timings(cv_device *dev, uint64_t ticket, cv_pass_timing *out, uint32_t capacity, uint32_t *count);

/* Whether the device is gone for good (its node died or disconnected, its GPU
 * was lost), so that a multi-device frame can go on without it. */
bool cv_device_is_lost(cv_device *dev);

/* For a watchdog that gave up on the device's GPU work (corvid-node's
 * --submit-timeout): host waits that hold the device (a read or write waiting
 * for the work that uses it) return CV_ERROR_DEVICE_LOST from then on instead
 * of waiting on. Any thread, takes no lock. The work may still be running: do
 * not destroy the device or its context (both wait for the GPU); leak them. */
void cv_device_abandon(cv_device *dev);

/* Encoder streams on the device's machine: for a device whose GPU is on another
 * machine (a proxy device), that machine reads the texture and encodes it there,
 * so only the encoded bytes cross the link; an H.264 stream keeps its state
 * between frames. Programs use them through frame_reader.h (media/), which
 * encodes here for devices without them. A backend without encoder streams
 * (cv_device_can_encode false) answers CV_ERROR_UNSUPPORTED.
 * open checks the codec and size (cv_encode_check_stream); read checks, under
 * the device lock, that t is a loaded texture, rect lies inside it with the
 * stream's size (else CV_ERROR_OUT_OF_RANGE / CV_ERROR_FORMAT_MISMATCH), its
 * format suits the codec (cv_encode_check_format) and the parameters
 * (cv_encode_check_params); it is ordered after submitted work that writes
 * the texture, like cv_device_read_texture, waits for the frame WITHOUT the
 * device lock (submissions and other calls go on while the device's machine
 * reads and encodes), and fills *out (zeroed on failure). A refused call
 * changes nothing and the stream goes on. Streams still open
 * when the device is destroyed are closed with it. */
bool cv_device_can_encode(cv_device *dev);
cv_result cv_device_encoder_open(cv_device *dev, cv_codec codec, uint32_t width, uint32_t height, uint32_t *stream);
cv_result cv_device_encoder_read(cv_device *dev, uint32_t stream, cv_texture t, cv_rect rect,
                                 const cv_encode_params *params, cv_encoded *out);
void cv_device_encoder_close(cv_device *dev, uint32_t stream);

/* Built-in backends. */
const cv_backend *cv_mock_backend(void);

#endif
