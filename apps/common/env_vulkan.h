/* The Vulkan backend's environment and command line, for programs (apps/,
 * bench/, tests that stand in for a program): the library reads neither, so
 * a program turns them into the config it passes (corvid/vulkan.h).
 *
 *   CORVID_VIRTUAL_GPUS=N                       device instances per adapter (1..64)
 *   CORVID_VGPU_DEVICE=auto|separate|shared     cv_vulkan_device_options.vgpu_device
 *   CORVID_CROSS_WAIT=auto|bridge|import        .cross_wait
 *   CORVID_LINK_QUEUE=compute|graphics|copy     .link_queue
 *   CORVID_TRACE_PATH=auto|compute|pipeline     .trace_path
 *   CORVID_VK_SYNC_VALIDATION=0|1               .sync_validation (off / on)
 *
 *   cv_vulkan_gpu_config config = { 0 };
 *   cv_result r = cv_env_vulkan_gpu_args(&argc, argv, &config);  // --gpus, --virtual-gpus, --adapters
 *   if (r == CV_OK)
 *       r = cv_env_vulkan_gpu_config(&config);                   // the variables above
 *   if (r == CV_OK)
 *       r = cv_vulkan_gpu_table_build(&config, &table);
 *   // a bad value: CV_ERROR_INVALID_ARGUMENT naming the flag or variable and what it takes
 *
 * Unset or empty variables leave their fields as they are. */
#ifndef CORVID_ENV_VULKAN_H
#define CORVID_ENV_VULKAN_H

#include "corvid/vulkan.h"

/* The device options' variables into *options; on a bad value nothing changes. */
cv_result cv_env_vulkan_options(cv_vulkan_device_options *options);
/* cv_env_vulkan_options into config->device, and CORVID_VIRTUAL_GPUS into
 * virtual_per_adapter where neither it nor total is set (a command line's
 * --gpus or --virtual-gpus wins, and the variable is then not even checked).
 * On a bad value nothing changes. */
cv_result cv_env_vulkan_gpu_config(cv_vulkan_gpu_config *config);
/* Takes "--virtual-gpus N" (instances per adapter), "--gpus N" (total devices)
 * and "--adapters LIST" out of argv (both "--flag N" and "--flag=N"), updating
 * *argc and the config (config->adapters then points into argv); other
 * arguments are kept in order. On a bad value nothing changes. */
cv_result cv_env_vulkan_gpu_args(int *argc, char **argv, cv_vulkan_gpu_config *config);

#endif
