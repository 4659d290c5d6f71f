/* The backend's environment switches (CORVID_VGPU_DEVICE, CORVID_CROSS_WAIT,
 * CORVID_LINK_QUEUE): one word from a fixed list, the first word the
 * default, taken also when the variable is unset or empty.
 *
 *   static const char *const words[] = { "auto", "bridge", "import" };
 *   uint32_t k;
 *   cv_result r = vk_env_choice("CORVID_CROSS_WAIT", getenv("CORVID_CROSS_WAIT"), words, 3, &k);
 *   // bad value: CV_ERROR_INVALID_ARGUMENT, "CORVID_CROSS_WAIT='x': expected auto, bridge or import" */
#ifndef CORVID_VK_ENV_H
#define CORVID_VK_ENV_H

#include <stdint.h>

#include "corvid/result.h"

/* *index = the position of value in words (0 when value is NULL or empty);
 * an unknown value fails naming the variable and every word. */
cv_result vk_env_choice(const char *name, const char *value, const char *const *words, uint32_t count,
                        uint32_t *index);

#endif
