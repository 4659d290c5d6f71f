/* Compute and graphics pipelines built from a registry entry and the embedded
 * SPIR-V. Bindings are pushed per command (VK_KHR_push_descriptor) into the
 * pipeline's one descriptor set layout, which follows the registry's binding
 * letters; graphics pipelines use dynamic rendering and pull their vertices. */
#ifndef CORVID_VK_PIPELINES_H
#define CORVID_VK_PIPELINES_H

#include "vk_device_core.h"

/* How the pipeline's shaders use one binding slot (from SPIR-V reflection). */
typedef struct vk_binding_use {
    VkPipelineStageFlags2 stages; /* 0 = no shader uses the slot */
    bool reads, writes;
} vk_binding_use;

struct vk_pipeline {
    const cv_pipeline_info *info;
    VkPipelineBindPoint bind_point;
    VkShaderStageFlags stages; /* for push constants */
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout;
    VkPipeline pipeline;
    vk_binding_use uses[CV_MAX_BINDINGS];
};

/* Pipelines behind handles (counted in the device's stats). */
cv_result vk_pipeline_create(cv_backend_device *bd, const cv_pipeline_info *info, vk_pipeline **out);
void vk_pipeline_destroy(cv_backend_device *bd, vk_pipeline *p);
/* The backend's own pipelines (not counted): built from an info that need not
 * be in the registry, released with the device. */
cv_result vk_pipeline_build(cv_backend_device *bd, const cv_pipeline_info *info, vk_pipeline **out);
void vk_pipeline_release(cv_backend_device *bd, vk_pipeline *p);

#endif
