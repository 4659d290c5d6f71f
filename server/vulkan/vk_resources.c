/* Buffer, texture and sampler objects. Memory comes from the block allocator
 * (vk_memory.h); textures are optimally tiled 2D images with one view, checked
 * against the adapter's format features before anything is created. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "vk_immediate.h"
#include "vk_resources.h"

VkFormat vk_format_of(cv_format f) {
    switch (f) {
    case CV_FORMAT_RGBA8_UNORM: return VK_FORMAT_R8G8B8A8_UNORM;
    case CV_FORMAT_RGBA16F: return VK_FORMAT_R16G16B16A16_SFLOAT;
    case CV_FORMAT_RGBA32F: return VK_FORMAT_R32G32B32A32_SFLOAT;
    case CV_FORMAT_R32F: return VK_FORMAT_R32_SFLOAT;
    case CV_FORMAT_RG16F: return VK_FORMAT_R16G16_SFLOAT;
    case CV_FORMAT_R11G11B10F: return VK_FORMAT_B10G11R11_UFLOAT_PACK32;
    case CV_FORMAT_R32_UINT: return VK_FORMAT_R32_UINT;
    case CV_FORMAT_D32F: return VK_FORMAT_D32_SFLOAT;
    default: return VK_FORMAT_UNDEFINED;
    }
}

/* ---- buffers ------------------------------------------------------------------- */

static VkBufferUsageFlags buffer_usage(uint32_t usage) {
    VkBufferUsageFlags u = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    if (usage & CV_BUFFER_USAGE_STORAGE)
        u |= VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
    if (usage & CV_BUFFER_USAGE_UNIFORM)
        u |= VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT;
    if (usage & CV_BUFFER_USAGE_INDEX)
        u |= VK_BUFFER_USAGE_INDEX_BUFFER_BIT;
    /* The bound on dispatch_indirect reads the counts by address (vk_indirect.h). */
    if (usage & CV_BUFFER_USAGE_INDIRECT)
        u |= VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
    return u;
}

static cv_result create_buffer(cv_backend_device *bd, VkDeviceSize size, VkBufferUsageFlags usage,
                               VkDeviceSize alignment, VkMemoryPropertyFlags required,
                               VkMemoryPropertyFlags preferred, const char *label, vk_buffer **out) {
    vk_buffer *b = calloc(1, sizeof(*b));
    if (!b)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: buffer '%s'", label);
    VkSharingMode sharing;
    uint32_t family_count;
    const uint32_t *families;
    vk_device_sharing(bd, &sharing, &family_count, &families);
    VkBufferCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
        .pNext = vk_memory_buffer_external(&bd->memory),
        .size = size,
        .usage = usage,
        .sharingMode = sharing,
        .queueFamilyIndexCount = family_count,
        .pQueueFamilyIndices = families,
    };
    VkResult vr = vkCreateBuffer(bd->device, &info, NULL, &b->buffer);
    if (vr != VK_SUCCESS) {
        free(b);
        return vk_fail(vr, "vkCreateBuffer '%s' (%llu bytes)", label, (unsigned long long)size);
    }
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(bd->device, b->buffer, &req);
    if (req.alignment < alignment)
        req.alignment = alignment;
    cv_result r = vk_memory_alloc(&bd->memory, &req, required, preferred, VK_MEMORY_LINEAR,
                                  label[0] ? label : "buffer", &b->memory);
    if (r == CV_OK) {
        vr = vkBindBufferMemory(bd->device, b->buffer, b->memory.memory, b->memory.offset);
        if (vr != VK_SUCCESS) {
            vk_memory_free(&bd->memory, &b->memory);
            r = vk_fail(vr, "vkBindBufferMemory '%s'", label);
        }
    }
    if (r != CV_OK) {
        vkDestroyBuffer(bd->device, b->buffer, NULL);
        free(b);
        return r;
    }
    b->size = size;
    if (usage & VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT) {
        VkBufferDeviceAddressInfo where = { .sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO,
                                            .buffer = b->buffer };
        b->address = vkGetBufferDeviceAddress(bd->device, &where);
    }
    vk_device_name(bd, VK_OBJECT_TYPE_BUFFER, (uint64_t)b->buffer, label);
    atomic_fetch_add(&bd->buffers, 1u);
    *out = b;
    return CV_OK;
}

cv_result vk_buffer_create_raw(cv_backend_device *bd, VkDeviceSize size, VkBufferUsageFlags usage,
                               VkDeviceSize alignment, const char *label, vk_buffer **out) {
    return create_buffer(bd, size, usage, alignment, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, label, out);
}

cv_result vk_buffer_create_host(cv_backend_device *bd, VkDeviceSize size, VkBufferUsageFlags usage, const char *label,
                                vk_buffer **out) {
    return create_buffer(bd, size, usage, 0, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
                         VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, label, out);
}

/* A buffer the core asked for reads as zeros until written: its memory may
 * hold what an earlier owner left (on a node, another session's data). */
cv_result vk_buffer_create(cv_backend_device *bd, const cv_buffer_desc *desc, vk_buffer **out) {
    vk_buffer *b = NULL;
    cv_result r = vk_buffer_create_raw(bd, desc->size, buffer_usage(desc->usage), 0, desc->label, &b);
    if (r == CV_OK && (r = vk_immediate_zero_buffer(bd, b)) != CV_OK)
        vk_buffer_destroy(bd, b);
    if (r == CV_OK)
        *out = b;
    return r;
}

void vk_buffer_destroy(cv_backend_device *bd, vk_buffer *b) {
    vk_immediate_forget_buffer(bd, b);
    vkDestroyBuffer(bd->device, b->buffer, NULL);
    vk_memory_free(&bd->memory, &b->memory);
    atomic_fetch_sub(&bd->buffers, 1u);
    free(b);
}

/* ---- textures ------------------------------------------------------------------ */

typedef struct usage_need {
    uint32_t usage; /* cv_texture_usage bit */
    VkImageUsageFlags vk_usage;
    VkFormatFeatureFlags feature;
    const char *name;
} usage_need;

static const usage_need usage_needs[] = {
    { CV_TEXTURE_USAGE_SAMPLED, VK_IMAGE_USAGE_SAMPLED_BIT, VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT, "sampling" },
    { CV_TEXTURE_USAGE_STORAGE, VK_IMAGE_USAGE_STORAGE_BIT, VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT, "storage" },
    { CV_TEXTURE_USAGE_COLOR_TARGET, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT, VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT,
      "color target" },
    { CV_TEXTURE_USAGE_DEPTH_TARGET, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
      VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT, "depth target" },
};

/* Vulkan usage for a texture, or CV_ERROR_UNSUPPORTED naming the missing feature. */
static cv_result texture_usage(const cv_backend_device *bd, const cv_texture_desc *desc, VkFormat format,
                               VkImageUsageFlags *out) {
    VkFormatProperties props;
    vkGetPhysicalDeviceFormatProperties(bd->adapter.physical, format, &props);
    VkFormatFeatureFlags have = props.optimalTilingFeatures;
    VkFormatFeatureFlags copies = VK_FORMAT_FEATURE_TRANSFER_SRC_BIT | VK_FORMAT_FEATURE_TRANSFER_DST_BIT;
    if ((have & copies) != copies)
        return cv_error(CV_ERROR_UNSUPPORTED, "texture '%s': format %s cannot be copied on '%s'", desc->label,
                        cv_format_name(desc->format), bd->adapter.info.name);
    VkImageUsageFlags usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    for (size_t i = 0; i < sizeof(usage_needs) / sizeof(usage_needs[0]); i++) {
        const usage_need *n = &usage_needs[i];
        if (!(desc->usage & n->usage))
            continue;
        if (!(have & n->feature))
            return cv_error(CV_ERROR_UNSUPPORTED, "texture '%s': format %s does not support %s on '%s'", desc->label,
                            cv_format_name(desc->format), n->name, bd->adapter.info.name);
        usage |= n->vk_usage;
    }
    *out = usage;
    return CV_OK;
}

/* Where a texture's memory comes from: the block allocator, or (`external`)
 * a dedicated opaque-fd allocation of its own, exported (fd < 0) or imported
 * from `fd` (which is set to -1 once Vulkan owns it). */
typedef struct image_memory {
    bool external;
    int fd;
    uint32_t memory_type; /* import: the exporter's */
    VkDeviceSize allocation_size;
} image_memory;

/* Whether the adapter can export and import such images as opaque fds. */
static bool external_image_ok(const cv_backend_device *bd, const VkImageCreateInfo *info) {
    VkPhysicalDeviceExternalImageFormatInfo ext = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTERNAL_IMAGE_FORMAT_INFO,
        .handleType = VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT
    };
    VkPhysicalDeviceImageFormatInfo2 format = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_IMAGE_FORMAT_INFO_2,
                                                .pNext = &ext,
                                                .format = info->format,
                                                .type = info->imageType,
                                                .tiling = info->tiling,
                                                .usage = info->usage,
                                                .flags = info->flags };
    VkExternalImageFormatProperties ext_props = { .sType = VK_STRUCTURE_TYPE_EXTERNAL_IMAGE_FORMAT_PROPERTIES };
    VkImageFormatProperties2 props = { .sType = VK_STRUCTURE_TYPE_IMAGE_FORMAT_PROPERTIES_2, .pNext = &ext_props };
    if (vkGetPhysicalDeviceImageFormatProperties2(bd->adapter.physical, &format, &props) != VK_SUCCESS)
        return false;
    VkExternalMemoryFeatureFlags f = ext_props.externalMemoryProperties.externalMemoryFeatures;
    return (f & VK_EXTERNAL_MEMORY_FEATURE_EXPORTABLE_BIT) && (f & VK_EXTERNAL_MEMORY_FEATURE_IMPORTABLE_BIT);
}

/* The dedicated opaque-fd memory of t (image_memory), bound at offset 0. */
static cv_result bind_external(cv_backend_device *bd, const cv_texture_desc *desc, vk_texture *t, image_memory *m) {
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(bd->device, t->image, &req);
    bool import = m->fd >= 0;
    uint32_t type = UINT32_MAX;
    if (import) {
        if (m->memory_type < 32 && (req.memoryTypeBits & (1u << m->memory_type)) && m->allocation_size >= req.size)
            type = m->memory_type;
    } else {
        for (uint32_t i = 0; i < bd->memory.properties.memoryTypeCount && type == UINT32_MAX; i++)
            if ((req.memoryTypeBits & (1u << i)) &&
                (bd->memory.properties.memoryTypes[i].propertyFlags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT))
                type = i;
    }
    if (type == UINT32_MAX)
        return cv_error(CV_ERROR_UNSUPPORTED, "texture '%s' on device '%s': %s", desc->label, bd->label,
                        import ? "the shared memory's type or size does not fit the image"
                               : "no device-local memory type can back a shareable image");
    VkMemoryDedicatedAllocateInfo dedicated = { .sType = VK_STRUCTURE_TYPE_MEMORY_DEDICATED_ALLOCATE_INFO,
                                                .image = t->image };
    VkExportMemoryAllocateInfo exp = { .sType = VK_STRUCTURE_TYPE_EXPORT_MEMORY_ALLOCATE_INFO,
                                       .pNext = &dedicated,
                                       .handleTypes = VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT };
    VkImportMemoryFdInfoKHR imp = { .sType = VK_STRUCTURE_TYPE_IMPORT_MEMORY_FD_INFO_KHR,
                                    .pNext = &dedicated,
                                    .handleType = VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT,
                                    .fd = m->fd };
    VkMemoryAllocateInfo alloc = { .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
                                   .pNext = import ? (const void *)&imp : (const void *)&exp,
                                   .allocationSize = import ? m->allocation_size : req.size,
                                   .memoryTypeIndex = type };
    VkResult vr = vkAllocateMemory(bd->device, &alloc, NULL, &t->own_memory);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkAllocateMemory (texture '%s', %s, device '%s')", desc->label,
                       import ? "imported from another device" : "shareable", bd->label);
    if (import)
        m->fd = -1; /* Vulkan owns it now */
    t->allocation_size = alloc.allocationSize;
    t->memory_type = type;
    t->exportable = !import;
    vr = vkBindImageMemory(bd->device, t->image, t->own_memory, 0);
    return vr == VK_SUCCESS ? CV_OK : vk_fail(vr, "vkBindImageMemory '%s'", desc->label);
}

static cv_result create_image(cv_backend_device *bd, const cv_texture_desc *desc, vk_texture *t,
                              VkImageUsageFlags usage, image_memory *m) {
    VkSharingMode sharing;
    uint32_t family_count;
    const uint32_t *families;
    vk_device_sharing(bd, &sharing, &family_count, &families);
    VkExternalMemoryImageCreateInfo external = { .sType = VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_IMAGE_CREATE_INFO,
                                                 .handleTypes = VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT };
    VkImageCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO,
        .pNext = vk_memory_image_external(&bd->memory),
        .imageType = VK_IMAGE_TYPE_2D,
        .format = t->format,
        .extent = { desc->width, desc->height, 1 },
        .mipLevels = 1,
        .arrayLayers = 1,
        .samples = VK_SAMPLE_COUNT_1_BIT,
        .tiling = VK_IMAGE_TILING_OPTIMAL,
        .usage = usage,
        .sharingMode = sharing,
        .queueFamilyIndexCount = family_count,
        .pQueueFamilyIndices = families,
        .initialLayout = VK_IMAGE_LAYOUT_UNDEFINED,
    };
    if (m->external) {
        /* Identical parameters on every device that shares the memory, so all
         * of them read its texels alike. */
        info.flags = VK_IMAGE_CREATE_ALIAS_BIT;
        info.pNext = &external;
        if (!bd->external_fd || !external_image_ok(bd, &info)) {
            if (m->fd >= 0)
                return cv_error(CV_ERROR_UNSUPPORTED,
                                "texture '%s': device '%s' cannot import %s images as opaque-fd memory", desc->label,
                                bd->label, cv_format_name(desc->format));
            m->external = false; /* not shareable here: an ordinary texture (aliases of it are refused) */
            info.flags = 0;
            info.pNext = vk_memory_image_external(&bd->memory);
        }
    }
    VkResult vr = vkCreateImage(bd->device, &info, NULL, &t->image);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkCreateImage '%s' (%ux%u %s)", desc->label, desc->width, desc->height,
                       cv_format_name(desc->format));
    cv_result r;
    if (m->external) {
        r = bind_external(bd, desc, t, m);
    } else {
        VkMemoryRequirements req;
        vkGetImageMemoryRequirements(bd->device, t->image, &req);
        r = vk_memory_alloc(&bd->memory, &req, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, VK_MEMORY_OPTIMAL,
                            desc->label[0] ? desc->label : "texture", &t->memory);
        if (r == CV_OK) {
            vr = vkBindImageMemory(bd->device, t->image, t->memory.memory, t->memory.offset);
            r = vr == VK_SUCCESS ? CV_OK : vk_fail(vr, "vkBindImageMemory '%s'", desc->label);
        }
        if (r == CV_ERROR_OUT_OF_MEMORY) /* say how large: "out of memory" alone does not say what to shrink */
            r = cv_error(r, "texture '%s' (%ux%u %s, %llu bytes) on device '%s': %s", desc->label, desc->width,
                         desc->height, cv_format_name(desc->format), (unsigned long long)req.size, bd->label,
                         cv_last_error());
    }
    if (r != CV_OK)
        return r;
    VkImageViewCreateInfo view = {
        .sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO,
        .image = t->image,
        .viewType = VK_IMAGE_VIEW_TYPE_2D,
        .format = t->format,
        .subresourceRange = { t->aspect, 0, 1, 0, 1 },
    };
    vr = vkCreateImageView(bd->device, &view, NULL, &t->view);
    return vr == VK_SUCCESS ? CV_OK : vk_fail(vr, "vkCreateImageView '%s'", desc->label);
}

static void release_image(cv_backend_device *bd, vk_texture *t) {
    vkDestroyImageView(bd->device, t->view, NULL);
    vkDestroyImage(bd->device, t->image, NULL);
    if (t->own_memory)
        vkFreeMemory(bd->device, t->own_memory, NULL);
    else
        vk_memory_free(&bd->memory, &t->memory);
}

static cv_result texture_make(cv_backend_device *bd, const cv_texture_desc *desc, image_memory *m, vk_texture **out) {
    VkFormat format = vk_format_of(desc->format);
    if (format == VK_FORMAT_UNDEFINED)
        return cv_error(CV_ERROR_UNSUPPORTED, "texture '%s': format %s has no Vulkan equivalent", desc->label,
                        cv_format_name(desc->format));
    VkImageUsageFlags usage = 0;
    cv_result r = texture_usage(bd, desc, format, &usage);
    if (r != CV_OK)
        return r;
    vk_texture *t = calloc(1, sizeof(*t));
    if (!t)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: texture '%s'", desc->label);
    t->format = format;
    t->aspect = cv_format_is_depth(desc->format) ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
    t->width = desc->width;
    t->height = desc->height;
    t->texel_bytes = cv_format_bytes(desc->format);
    t->clear = m->fd < 0; /* new memory reads as zeros until written; an alias shows the exporter's texels */
    r = create_image(bd, desc, t, usage, m);
    if (t->memory.zeroed)
        t->clear = false; /* fresh pages (vk_memory.h) */
    if (r == CV_OK)
        r = vk_immediate_add_image(bd, t);
    if (r != CV_OK) {
        release_image(bd, t);
        free(t);
        return r;
    }
    vk_device_name(bd, VK_OBJECT_TYPE_IMAGE, (uint64_t)t->image, desc->label);
    atomic_fetch_add(&bd->images, 1u);
    *out = t;
    return CV_OK;
}

cv_result vk_texture_create(cv_backend_device *bd, const cv_texture_desc *desc, vk_texture **out) {
    image_memory m = { .external = (desc->usage & CV_TEXTURE_USAGE_SHARED) != 0, .fd = -1 };
    return texture_make(bd, desc, &m, out);
}

cv_result vk_texture_alias(cv_backend_device *bd, const cv_texture_desc *desc, cv_backend_device *src_bd,
                           vk_texture *src, vk_texture **out) {
    if (!src->exportable)
        return cv_error(CV_ERROR_UNSUPPORTED,
                        "texture '%s': device '%s' could not make it shareable (its adapter does not export %s "
                        "images as opaque fds), so device '%s' cannot alias it",
                        desc->label, src_bd->label, cv_format_name(desc->format), bd->label);
    if (desc->width != src->width || desc->height != src->height || vk_format_of(desc->format) != src->format)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "texture '%s': an alias must match the shared image", desc->label);
    VkMemoryGetFdInfoKHR get = { .sType = VK_STRUCTURE_TYPE_MEMORY_GET_FD_INFO_KHR,
                                 .memory = src->own_memory,
                                 .handleType = VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT };
    int fd = -1;
    VkResult vr = src_bd->get_memory_fd(src_bd->device, &get, &fd);
    if (vr != VK_SUCCESS)
        return vk_fail(vr, "vkGetMemoryFdKHR (texture '%s', device '%s')", desc->label, src_bd->label);
    image_memory m = {
        .external = true, .fd = fd, .memory_type = src->memory_type, .allocation_size = src->allocation_size
    };
    vk_texture *t = NULL;
    cv_result r = texture_make(bd, desc, &m, &t);
    if (m.fd >= 0)
        close(m.fd); /* not imported */
    /* First layouts now, on both, before either device writes a texel. */
    if (r == CV_OK)
        r = vk_immediate_flush(src_bd);
    if (r == CV_OK)
        r = vk_immediate_flush(bd);
    if (r != CV_OK && t)
        vk_texture_destroy(bd, t);
    if (r == CV_OK)
        *out = t;
    return r;
}

void vk_texture_destroy(cv_backend_device *bd, vk_texture *t) {
    vk_immediate_forget_image(bd, t);
    release_image(bd, t);
    atomic_fetch_sub(&bd->images, 1u);
    free(t);
}

/* ---- host import --------------------------------------------------------------- */

/* Whether every buffer and every image this backend makes can be bound to
 * imported host memory (vk_memory_enable_host_import): buffers with all their
 * usages, images in every format with every usage the format supports. */
bool vk_resources_host_import_ok(const cv_backend_device *bd) {
    const VkExternalMemoryFeatureFlags importable = VK_EXTERNAL_MEMORY_FEATURE_IMPORTABLE_BIT;
    VkPhysicalDeviceExternalBufferInfo buffer = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTERNAL_BUFFER_INFO,
        .usage = buffer_usage(~0u) | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT |
                 (bd->ray_tracing ? VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR |
                                        VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR |
                                        VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR
                                  : 0),
        .handleType = VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT
    };
    VkExternalBufferProperties buffer_props = { .sType = VK_STRUCTURE_TYPE_EXTERNAL_BUFFER_PROPERTIES };
    vkGetPhysicalDeviceExternalBufferProperties(bd->adapter.physical, &buffer, &buffer_props);
    if (!(buffer_props.externalMemoryProperties.externalMemoryFeatures & importable))
        return false;
    for (int f = 0; f < CV_FORMAT_COUNT; f++) {
        VkFormat format = vk_format_of((cv_format)f);
        VkFormatProperties props;
        if (format == VK_FORMAT_UNDEFINED)
            continue;
        vkGetPhysicalDeviceFormatProperties(bd->adapter.physical, format, &props);
        VkImageUsageFlags usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
        for (size_t i = 0; i < sizeof(usage_needs) / sizeof(usage_needs[0]); i++)
            if (props.optimalTilingFeatures & usage_needs[i].feature)
                usage |= usage_needs[i].vk_usage;
        VkPhysicalDeviceExternalImageFormatInfo ext = {
            .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTERNAL_IMAGE_FORMAT_INFO,
            .handleType = VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT
        };
        VkPhysicalDeviceImageFormatInfo2 info = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_IMAGE_FORMAT_INFO_2,
                                                  .pNext = &ext,
                                                  .format = format,
                                                  .type = VK_IMAGE_TYPE_2D,
                                                  .tiling = VK_IMAGE_TILING_OPTIMAL,
                                                  .usage = usage };
        VkExternalImageFormatProperties ext_props = { .sType = VK_STRUCTURE_TYPE_EXTERNAL_IMAGE_FORMAT_PROPERTIES };
        VkImageFormatProperties2 image_props = { .sType = VK_STRUCTURE_TYPE_IMAGE_FORMAT_PROPERTIES_2,
                                                 .pNext = &ext_props };
        if (vkGetPhysicalDeviceImageFormatProperties2(bd->adapter.physical, &info, &image_props) != VK_SUCCESS ||
            !(ext_props.externalMemoryProperties.externalMemoryFeatures & importable))
            return false;
    }
    return true;
}

/* ---- samplers ------------------------------------------------------------------ */

cv_result vk_sampler_create(cv_backend_device *bd, const cv_sampler_desc *desc, vk_sampler **out) {
    vk_sampler *s = calloc(1, sizeof(*s));
    if (!s)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: sampler '%s'", desc->label);
    VkFilter filter = desc->filter == CV_FILTER_NEAREST ? VK_FILTER_NEAREST : VK_FILTER_LINEAR;
    VkSamplerAddressMode address = desc->address == CV_ADDRESS_REPEAT ? VK_SAMPLER_ADDRESS_MODE_REPEAT
                                                                      : VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    VkSamplerCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO,
        .magFilter = filter,
        .minFilter = filter,
        .mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST,
        .addressModeU = address,
        .addressModeV = address,
        .addressModeW = address,
        .maxLod = 0.0f,
    };
    VkResult vr = vkCreateSampler(bd->device, &info, NULL, &s->sampler);
    if (vr != VK_SUCCESS) {
        free(s);
        return vk_fail(vr, "vkCreateSampler '%s'", desc->label);
    }
    vk_device_name(bd, VK_OBJECT_TYPE_SAMPLER, (uint64_t)s->sampler, desc->label);
    atomic_fetch_add(&bd->samplers, 1u);
    *out = s;
    return CV_OK;
}

void vk_sampler_destroy(cv_backend_device *bd, vk_sampler *s) {
    vkDestroySampler(bd->device, s->sampler, NULL);
    atomic_fetch_sub(&bd->samplers, 1u);
    free(s);
}
