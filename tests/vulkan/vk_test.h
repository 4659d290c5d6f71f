/* Helpers shared by the Vulkan backend tests: devices with the validation
 * layer on, one-call list execution, and the end-of-test cleanliness check
 * (every test fails on any validation error or warning). */
#ifndef CORVID_TEST_VK_TEST_H
#define CORVID_TEST_VK_TEST_H

#include "check.h"
#include "corvid/corvid.h"
#include "corvid/vulkan.h"

/* The adapter the tests run on: CORVID_TEST_ADAPTER (e.g. "NVIDIA", "H100") or,
 * by default, "llvmpipe", so CI always tests lavapipe even where a GPU exists. */
const char *vkt_adapter(void);
/* Whether the tests run on lavapipe (where lavapipe-only facts are checked too). */
bool vkt_is_lavapipe(void);
/* A validated Vulkan device on `adapter` (NULL = vkt_adapter()) labelled `label`. */
cv_result vkt_device(cv_context *ctx, const char *adapter, const char *label, cv_device **out);
/* Creates and loads a buffer/texture/sampler/pipeline on dev (0 handle on failure). */
cv_buffer vkt_buffer(cv_context *ctx, cv_device *dev, uint64_t size, uint32_t usage, const char *label);
cv_texture vkt_texture(cv_context *ctx, cv_device *dev, uint32_t w, uint32_t h, cv_format f, uint32_t usage,
                       const char *label);
cv_sampler vkt_sampler(cv_context *ctx, cv_device *dev, cv_filter filter, cv_address_mode address);
cv_pipeline vkt_pipeline(cv_context *ctx, cv_device *dev, const char *name);
/* Two validated virtual GPUs of vkt_adapter() (labels gpu0, gpu1; both NULL on failure). */
cv_result vkt_two_virtual_gpus(cv_context *ctx, cv_device *out[2]);
/* Submits an ended list and waits for it; *ticket (if given) gets its ticket. */
cv_result vkt_run(cv_device *dev, cv_cmdlist list, uint64_t *ticket);
/* Checks that the validation layer reported nothing, then reports
 * (check_report: nothing live, no Vulkan memory block either). */
int vkt_report(const char *name);

#endif
