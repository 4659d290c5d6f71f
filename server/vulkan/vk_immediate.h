/* Immediate work: a command buffer recorded, submitted and waited for on the
 * spot, for host transfers and the first layout transition of new images. */
#ifndef CORVID_VK_IMMEDIATE_H
#define CORVID_VK_IMMEDIATE_H

#include "vk_device_core.h"

cv_result vk_immediate_init(cv_backend_device *bd);
void vk_immediate_finish(cv_backend_device *bd);

/* Begins the immediate command buffer; pending image initialisations are
 * recorded first, so the caller may use any image. */
cv_result vk_immediate_begin(cv_backend_device *bd, VkCommandBuffer *out);
/* Ends it, submits it on the graphics queue and waits until it finished. Lists
 * submitted later wait for it on the GPU too (vk_submit.c), which orders their
 * accesses after its writes. */
cv_result vk_immediate_end(cv_backend_device *bd);
/* Runs pending image and buffer initialisations now, if there are any. */
cv_result vk_immediate_flush(cv_backend_device *bd);

/* New images start in VK_IMAGE_LAYOUT_UNDEFINED; every compiled list assumes
 * images rest in VK_IMAGE_LAYOUT_GENERAL between lists. The transition is
 * batched: it runs before the next submission or host transfer, and an image
 * destroyed before then never needs it. An image with `clear` set is also
 * cleared to zero there (its memory may hold what an earlier owner left:
 * another session's data on a node). */
cv_result vk_immediate_add_image(cv_backend_device *bd, vk_texture *tex);
void vk_immediate_forget_image(cv_backend_device *bd, vk_texture *tex);

/* Zeroes a new buffer before anyone can read it: at once on the host where
 * its memory is mapped, else by a fill batched like the image initialisations
 * above (before the next submission or host transfer). */
cv_result vk_immediate_zero_buffer(cv_backend_device *bd, vk_buffer *buf);
void vk_immediate_forget_buffer(cv_backend_device *bd, vk_buffer *buf);

#endif
