/* The Vulkan adapter tests render on: CORVID_TEST_ADAPTER, default
 * "llvmpipe" (lavapipe, as in CI). One place for what several test files
 * each defined as their own test_adapter().
 *
 *     cv_vulkan_gpu_table table;
 *     cv_vulkan_gpu_table_build(&(cv_vulkan_gpu_config){ .total = 2, .adapters = cv_test_adapter() }, &table);
 */
#ifndef CORVID_TEST_ADAPTER_H
#define CORVID_TEST_ADAPTER_H

const char *cv_test_adapter(void);

#endif
