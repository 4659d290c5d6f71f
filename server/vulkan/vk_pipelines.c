/* Pipeline creation. On a VkDevice shared by virtual GPUs (vk_shared.h) the
 * instances share each pipeline, built once and refcounted. Each shader is checked against its registry entry before
 * Vulkan sees it: binding kinds must match the registry letters, compute local
 * sizes must equal the entry's, so registry and shaders cannot drift apart
 * unnoticed. Fixed state of every graphics pipeline: triangle list, no culling,
 * counter-clockwise front faces, depth test LESS with writes when the entry has
 * a depth format, no blending, viewport and scissor set per render pass. */
#include <stdlib.h>
#include <string.h>

#include "corvid/shaders.h"
#include "vk_pipelines.h"
#include "vk_resources.h"
#include "vk_shared.h"
#include "vk_spirv.h"

static const VkDescriptorType descriptor_types[] = {
    [CV_BINDING_STORAGE_BUFFER] = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
    [CV_BINDING_UNIFORM_BUFFER] = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER,
    [CV_BINDING_STORAGE_TEXTURE] = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
    [CV_BINDING_SAMPLED_TEXTURE] = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
};

typedef struct shader_stage {
    const char *file;
    VkShaderStageFlagBits stage;
    VkPipelineStageFlags2 pipeline_stage;
    VkShaderModule module;
} shader_stage;

/* Loads, checks and creates the module of one stage; records its binding uses in p. */
static cv_result load_stage(cv_backend_device *bd, vk_pipeline *p, shader_stage *s) {
    const cv_pipeline_info *info = p->info;
    size_t size = 0;
    const uint32_t *words = cv_shader_spirv(s->file, &size);
    if (!words)
        return cv_error(CV_ERROR_NOT_FOUND, "pipeline '%s': shader '%s' is not among the embedded shaders",
                        info->name, s->file ? s->file : "(none)");
    vk_spirv_info reflected;
    cv_result r = vk_spirv_reflect(words, size, s->file, &reflected);
    if (r != CV_OK)
        return r;
    if (info->kind == CV_PIPELINE_COMPUTE && reflected.has_local_size &&
        memcmp(reflected.local_size, info->local_size, sizeof(info->local_size)) != 0)
        return cv_error(CV_ERROR_BINDING_MISMATCH,
                        "pipeline '%s': shader '%s' has local size %ux%ux%u, the registry says %ux%ux%u", info->name,
                        s->file, reflected.local_size[0], reflected.local_size[1], reflected.local_size[2],
                        info->local_size[0], info->local_size[1], info->local_size[2]);
    for (uint32_t i = 0; i < CV_MAX_BINDINGS; i++) {
        const vk_spirv_binding *b = &reflected.bindings[i];
        if (!b->used)
            continue;
        if (i >= info->binding_count)
            return cv_error(CV_ERROR_BINDING_MISMATCH,
                            "pipeline '%s': shader '%s' uses binding %u, the registry has %u", info->name, s->file, i,
                            info->binding_count);
        if (b->kind != info->bindings[i])
            return cv_error(CV_ERROR_BINDING_MISMATCH,
                            "pipeline '%s': shader '%s' declares binding %u as a %s, the "
                            "registry as a %s",
                            info->name, s->file, i, cv_binding_kind_name(b->kind),
                            cv_binding_kind_name(info->bindings[i]));
        p->uses[i].stages |= s->pipeline_stage;
        p->uses[i].reads |= b->reads;
        p->uses[i].writes |= b->writes;
    }
    VkShaderModuleCreateInfo module_info = { .sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
                                             .codeSize = size,
                                             .pCode = words };
    VkResult vr = vkCreateShaderModule(bd->device, &module_info, NULL, &s->module);
    return vr == VK_SUCCESS ? CV_OK : vk_fail(vr, "vkCreateShaderModule '%s'", s->file);
}

static cv_result create_layouts(cv_backend_device *bd, vk_pipeline *p) {
    const cv_pipeline_info *info = p->info;
    VkDescriptorSetLayoutBinding bindings[CV_MAX_BINDINGS];
    for (uint32_t i = 0; i < info->binding_count; i++)
        bindings[i] = (VkDescriptorSetLayoutBinding){
            .binding = i,
            .descriptorType = descriptor_types[info->bindings[i]],
            .descriptorCount = 1,
            .stageFlags = p->stages,
        };
    VkDescriptorSetLayoutCreateInfo set_info = {
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
        .flags = VK_DESCRIPTOR_SET_LAYOUT_CREATE_PUSH_DESCRIPTOR_BIT_KHR,
        .bindingCount = info->binding_count,
        .pBindings = bindings,
    };
    VkResult vr = vkCreateDescriptorSetLayout(bd->device, &set_info, NULL, &p->set_layout);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkCreateDescriptorSetLayout for pipeline '%s'", info->name);
    VkPushConstantRange push = { .stageFlags = p->stages, .offset = 0, .size = info->push_constant_size };
    VkPipelineLayoutCreateInfo layout_info = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
        .setLayoutCount = 1,
        .pSetLayouts = &p->set_layout,
        .pushConstantRangeCount = info->push_constant_size ? 1u : 0u,
        .pPushConstantRanges = &push,
    };
    vr = vkCreatePipelineLayout(bd->device, &layout_info, NULL, &p->layout);
    return vr == VK_SUCCESS ? CV_OK : vk_fail(vr, "vkCreatePipelineLayout for pipeline '%s'", info->name);
}

static cv_result create_compute(cv_backend_device *bd, vk_pipeline *p, shader_stage *s) {
    VkComputePipelineCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
        .stage = { .sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                   .stage = s->stage,
                   .module = s->module,
                   .pName = "main" },
        .layout = p->layout,
    };
    VkResult vr = vkCreateComputePipelines(bd->device, VK_NULL_HANDLE, 1, &info, NULL, &p->pipeline);
    return vr == VK_SUCCESS ? CV_OK : vk_fail(vr, "vkCreateComputePipelines '%s'", p->info->name);
}

static cv_result create_graphics(cv_backend_device *bd, vk_pipeline *p, shader_stage *stages) {
    const cv_pipeline_info *info = p->info;
    VkFormat color_formats[CV_MAX_COLOR_TARGETS];
    VkPipelineColorBlendAttachmentState blend[CV_MAX_COLOR_TARGETS];
    uint32_t color_count = 0;
    while (color_count < CV_MAX_COLOR_TARGETS && info->color_formats[color_count] != CV_FORMAT_UNDEFINED) {
        color_formats[color_count] = vk_format_of(info->color_formats[color_count]);
        blend[color_count] = (VkPipelineColorBlendAttachmentState){
            .colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT |
                              VK_COLOR_COMPONENT_A_BIT,
        };
        color_count++;
    }
    bool depth = info->depth_format != CV_FORMAT_UNDEFINED;
    VkPipelineRenderingCreateInfo rendering = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO,
        .colorAttachmentCount = color_count,
        .pColorAttachmentFormats = color_formats,
        .depthAttachmentFormat = depth ? vk_format_of(info->depth_format) : VK_FORMAT_UNDEFINED,
    };
    VkPipelineShaderStageCreateInfo shader_infos[2];
    for (int i = 0; i < 2; i++)
        shader_infos[i] = (VkPipelineShaderStageCreateInfo){
            .sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
            .stage = stages[i].stage,
            .module = stages[i].module,
            .pName = "main"
        };
    VkPipelineVertexInputStateCreateInfo vertex_input = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO
    };
    VkPipelineInputAssemblyStateCreateInfo assembly = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO,
        .topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST
    };
    VkPipelineViewportStateCreateInfo viewport = { .sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO,
                                                   .viewportCount = 1,
                                                   .scissorCount = 1 };
    VkPipelineRasterizationStateCreateInfo raster = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO,
        .polygonMode = VK_POLYGON_MODE_FILL,
        .cullMode = VK_CULL_MODE_NONE,
        .frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE,
        .lineWidth = 1.0f,
    };
    VkPipelineMultisampleStateCreateInfo multisample = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO,
        .rasterizationSamples = VK_SAMPLE_COUNT_1_BIT
    };
    VkPipelineDepthStencilStateCreateInfo depth_state = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO,
        .depthTestEnable = depth,
        .depthWriteEnable = depth,
        .depthCompareOp = VK_COMPARE_OP_LESS,
    };
    VkPipelineColorBlendStateCreateInfo blend_state = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO,
        .attachmentCount = color_count,
        .pAttachments = blend,
    };
    VkDynamicState dynamic[] = { VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR };
    VkPipelineDynamicStateCreateInfo dynamic_state = { .sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO,
                                                       .dynamicStateCount = 2,
                                                       .pDynamicStates = dynamic };
    VkGraphicsPipelineCreateInfo pipeline_info = {
        .sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO,
        .pNext = &rendering,
        .stageCount = 2,
        .pStages = shader_infos,
        .pVertexInputState = &vertex_input,
        .pInputAssemblyState = &assembly,
        .pViewportState = &viewport,
        .pRasterizationState = &raster,
        .pMultisampleState = &multisample,
        .pDepthStencilState = &depth_state,
        .pColorBlendState = &blend_state,
        .pDynamicState = &dynamic_state,
        .layout = p->layout,
    };
    VkResult vr = vkCreateGraphicsPipelines(bd->device, VK_NULL_HANDLE, 1, &pipeline_info, NULL, &p->pipeline);
    return vr == VK_SUCCESS ? CV_OK : vk_fail(vr, "vkCreateGraphicsPipelines '%s'", info->name);
}

static void free_own(cv_backend_device *bd, vk_pipeline *p) {
    vkDestroyPipeline(bd->device, p->pipeline, NULL);
    vkDestroyPipelineLayout(bd->device, p->layout, NULL);
    vkDestroyDescriptorSetLayout(bd->device, p->set_layout, NULL);
    free(p);
}

void vk_pipeline_destroy(cv_backend_device *bd, vk_pipeline *p) {
    vk_pipeline_release(bd, p);
    atomic_fetch_sub(&bd->pipelines, 1u);
}

cv_result vk_pipeline_create(cv_backend_device *bd, const cv_pipeline_info *info, vk_pipeline **out) {
    cv_result r = vk_pipeline_build(bd, info, out);
    if (r == CV_OK)
        atomic_fetch_add(&bd->pipelines, 1u);
    return r;
}

static cv_result build_own(cv_backend_device *bd, const cv_pipeline_info *info, vk_pipeline **out) {
    if (!info)
        return cv_error(CV_ERROR_UNKNOWN_PIPELINE, "vulkan: pipeline without a registry entry");
    if (info->push_constant_size % 4 || info->push_constant_size > bd->limits.maxPushConstantsSize)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED,
                        "pipeline '%s': %u bytes of push constants (a multiple of 4, at most "
                        "%u on '%s')",
                        info->name, info->push_constant_size, bd->limits.maxPushConstantsSize, bd->adapter.info.name);
    vk_pipeline *p = calloc(1, sizeof(*p));
    if (!p)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: pipeline '%s'", info->name);
    p->info = info;
    bool compute = info->kind == CV_PIPELINE_COMPUTE;
    shader_stage stages[2] = {
        { compute ? info->compute_shader : info->vertex_shader,
          compute ? VK_SHADER_STAGE_COMPUTE_BIT : VK_SHADER_STAGE_VERTEX_BIT,
          compute ? VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT : VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT, VK_NULL_HANDLE },
        { info->fragment_shader, VK_SHADER_STAGE_FRAGMENT_BIT, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
          VK_NULL_HANDLE },
    };
    uint32_t stage_count = compute ? 1 : 2;
    p->bind_point = compute ? VK_PIPELINE_BIND_POINT_COMPUTE : VK_PIPELINE_BIND_POINT_GRAPHICS;
    p->stages = compute ? VK_SHADER_STAGE_COMPUTE_BIT : VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
    cv_result r = CV_OK;
    for (uint32_t i = 0; i < stage_count && r == CV_OK; i++)
        r = load_stage(bd, p, &stages[i]);
    if (r == CV_OK)
        r = create_layouts(bd, p);
    if (r == CV_OK)
        r = compute ? create_compute(bd, p, &stages[0]) : create_graphics(bd, p, stages);
    for (uint32_t i = 0; i < stage_count; i++)
        vkDestroyShaderModule(bd->device, stages[i].module, NULL);
    if (r != CV_OK) {
        free_own(bd, p);
        return r;
    }
    *out = p;
    return CV_OK;
}

/* On a shared VkDevice: the entry's pipeline, built by the first instance that
 * asks (under the lock, so a second one waits and reuses it), see vk_shared.h. */
static cv_result build_shared(cv_backend_device *bd, const cv_pipeline_info *info, vk_pipeline **out) {
    vk_shared_device *s = bd->shared;
    cv_result r = CV_OK;
    pthread_mutex_lock(&s->pipeline_lock);
    vk_shared_pipeline *e = s->pipelines;
    while (e && memcmp(&e->info, info, sizeof(*info)) != 0)
        e = e->next;
    if (e) {
        e->refs++;
    } else if (!(e = calloc(1, sizeof(*e)))) {
        r = cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: pipeline '%s'", info->name);
    } else if ((r = build_own(bd, info, &e->pipeline)) != CV_OK) {
        free(e);
        e = NULL;
    } else {
        memcpy(&e->info, info, sizeof(*info));
        e->refs = 1;
        e->next = s->pipelines;
        s->pipelines = e;
    }
    pthread_mutex_unlock(&s->pipeline_lock);
    if (e)
        *out = e->pipeline;
    return r;
}

/* Drops one instance's reference; the last destroys the pipeline. */
static void release_shared(cv_backend_device *bd, vk_pipeline *p) {
    vk_shared_device *s = bd->shared;
    pthread_mutex_lock(&s->pipeline_lock);
    vk_shared_pipeline **link = &s->pipelines;
    while (*link && (*link)->pipeline != p)
        link = &(*link)->next;
    vk_shared_pipeline *last = NULL;
    if (*link && --(*link)->refs == 0) {
        last = *link;
        *link = last->next;
    }
    pthread_mutex_unlock(&s->pipeline_lock);
    if (last) {
        free_own(bd, p);
        free(last);
    }
}

cv_result vk_pipeline_build(cv_backend_device *bd, const cv_pipeline_info *info, vk_pipeline **out) {
    if (info && bd->shared)
        return build_shared(bd, info, out);
    return build_own(bd, info, out);
}

void vk_pipeline_release(cv_backend_device *bd, vk_pipeline *p) {
    if (bd->shared)
        release_shared(bd, p);
    else
        free_own(bd, p);
}
