/* Starting and stopping the Vulkan device behind one cv_device. The backend is
 * layered after Mesa's Vulkan runtime, top to bottom; a module includes only
 * modules below it (tree_check.py graph finds no loop):
 *
 *   vk_backend (the cv_backend table), vk_gpu_table (virtual GPU tables)
 *   vk_device: creates the VkDevice with what the subsystems ask for, starts
 *              and stops every subsystem in order (it includes all of them)
 *   the subsystems, each owning its state behind its own module; one uses
 *   only those listed after it:
 *     vk_submit, vk_compile, vk_timestamps         lists: recording, submitting
 *     vk_trace, vk_trace_calibrate, vk_trace_rt, vk_trace_job    trace_rays
 *     vk_indirect, vk_pipelines                    kernels
 *     vk_link_async, vk_link, vk_host_transfer     copies: device to device, host
 *     vk_resources, vk_immediate, vk_objects       device objects, their first init
 *     vk_cross_wait, vk_bridge, vk_shared          cross-device waits, virtual
 *                                                  GPUs on one VkDevice
 *   vk_device_core: the device's state and shared services (queues, timelines
 *              and host waits, debug names, sharing modes, extension checks)
 *   vk_instance, vk_adapters, vk_memory, vk_barriers, vk_spirv, vk_common
 *
 * Where a lower module must call back up (the trace measurement runs the
 * tracer's paths), the upper one hands it the calls (vk_trace_paths). */
#ifndef CORVID_VK_DEVICE_H
#define CORVID_VK_DEVICE_H

#include "vk_device_core.h"

/* The device of `desc` (backend.h: device_create). */
cv_result vk_device_create(const cv_device_desc *desc, cv_device_info *info, cv_backend_device **out);
void vk_device_destroy(cv_backend_device *bd);

#endif
