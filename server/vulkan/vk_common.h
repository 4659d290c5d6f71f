/* What every file of the Vulkan backend shares: the Vulkan and core headers and
 * the translation of VkResult failures into cv_error() codes and messages. */
#ifndef CORVID_VK_COMMON_H
#define CORVID_VK_COMMON_H

#include <vulkan/vulkan.h>

#include "corvid/backend.h"
#include "corvid/vulkan.h"

/* "VK_ERROR_OUT_OF_DEVICE_MEMORY", ... */
const char *vk_result_name(VkResult r);

/* Records "<what>: <VkResult name>" and returns the matching cv_result:
 * out of memory, device lost, unsupported (missing feature/extension/format),
 * timeout, or CV_ERROR_BACKEND for anything else. */
cv_result vk_fail(VkResult r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#endif
