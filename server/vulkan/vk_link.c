/* Cross-device link stagings and copies (see vk_link.h). */
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "vk_host_transfer.h"
#include "vk_immediate.h"
#include "vk_link.h"

typedef struct vk_staging {
    struct vk_staging *next;
    cv_staging_kind kind;
    uint64_t key; /* EXPORT, IMPORT */
    void *host;   /* HOST */
    VkBuffer buffer;
    VkDeviceMemory memory;
    VkDeviceSize size;
    uint32_t memory_type; /* EXPORT: what an importer must allocate */
    VkDeviceSize allocation_size;
    bool owned; /* the caller's (cv_staging_desc.owned): never cached, freed by vk_link_release */
} vk_staging;

/* process-wide: exported stagings' keys (backend.h: cv_staging_desc.key) must
 * be unique in the process, since importers on any device cache by them. */
static atomic_uint_fast64_t next_key = 1;

static const VkBufferUsageFlags usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;

void vk_link_caps(cv_backend_device *bd, cv_link_caps *out) {
    memset(out, 0, sizeof(*out));
    memcpy(out->driver_uuid, bd->driver_uuid, 16);
    memcpy(out->device_uuid, bd->device_uuid, 16);
    out->shared_memory = bd->external_fd;
    out->host_import = bd->external_host;
    out->host_alignment = bd->host_import_alignment;
    if (!bd->external_fd)
        snprintf(out->shared_missing, sizeof(out->shared_missing), "%s", VK_KHR_EXTERNAL_MEMORY_FD_EXTENSION_NAME);
    if (!bd->external_host)
        snprintf(out->host_missing, sizeof(out->host_missing), "%s", VK_EXT_EXTERNAL_MEMORY_HOST_EXTENSION_NAME);
    out->device_group = (uint64_t)(uintptr_t)bd->shared; /* instances of one shared VkDevice (vk_shared.h) */
    out->wait_import = bd->cross_import;
    out->wait_import_required = bd->cross_required;
    if (!bd->cross_import)
        snprintf(out->wait_missing, sizeof(out->wait_missing), "%s",
                 bd->cross_missing[0] ? bd->cross_missing : "the cross_wait option bridge");
}

static void staging_free(cv_backend_device *bd, vk_staging *s) {
    vkDestroyBuffer(bd->device, s->buffer, NULL);
    vkFreeMemory(bd->device, s->memory, NULL);
    free(s);
}

void vk_link_finish(cv_backend_device *bd) {
    while (bd->links) {
        vk_staging *s = bd->links;
        bd->links = s->next;
        staging_free(bd, s);
    }
}

/* Adds s at the head; evicts the oldest import beyond VK_LINK_CACHE. Any
 * copy through an evicted staging has finished (copies are synchronous). */
static void cache_add(cv_backend_device *bd, vk_staging *s) {
    s->next = bd->links;
    bd->links = s;
    uint32_t imports = 0;
    vk_staging **link = &bd->links, **oldest = NULL;
    for (; *link; link = &(*link)->next)
        if ((*link)->kind != CV_STAGING_EXPORT && !(*link)->owned) {
            imports++;
            oldest = link;
        }
    if (imports > VK_LINK_CACHE && oldest) {
        vk_staging *gone = *oldest;
        *oldest = gone->next;
        staging_free(bd, gone);
    }
}

static vk_staging *cache_find(cv_backend_device *bd, const cv_staging_desc *d) {
    for (vk_staging *s = bd->links; s; s = s->next) {
        if (s->owned)
            continue;
        bool match = d->kind == CV_STAGING_HOST     ? s->kind == CV_STAGING_HOST && s->host == d->host
                     : d->kind == CV_STAGING_EXPORT ? s->kind == CV_STAGING_EXPORT
                                                    : s->kind != CV_STAGING_HOST && s->key == d->key;
        if (match && s->size >= d->size)
            return s;
    }
    return NULL;
}

/* Whether the driver can export (or import) such buffers, and if dedicated memory is required. */
static cv_result check_external(cv_backend_device *bd, VkExternalMemoryHandleTypeFlagBits type, bool export,
                                bool *dedicated) {
    VkPhysicalDeviceExternalBufferInfo info = { .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_EXTERNAL_BUFFER_INFO,
                                                .usage = usage,
                                                .handleType = type };
    VkExternalBufferProperties props = { .sType = VK_STRUCTURE_TYPE_EXTERNAL_BUFFER_PROPERTIES };
    vkGetPhysicalDeviceExternalBufferProperties(bd->adapter.physical, &info, &props);
    VkExternalMemoryFeatureFlags f = props.externalMemoryProperties.externalMemoryFeatures;
    VkExternalMemoryFeatureFlags need = export ? VK_EXTERNAL_MEMORY_FEATURE_EXPORTABLE_BIT
                                               : VK_EXTERNAL_MEMORY_FEATURE_IMPORTABLE_BIT;
    *dedicated = f & VK_EXTERNAL_MEMORY_FEATURE_DEDICATED_ONLY_BIT;
    if (!(f & need))
        return cv_error(CV_ERROR_UNSUPPORTED, "device '%s': transfer buffers cannot be %s as %s memory", bd->label,
                        export ? "exported" : "imported",
                        type == VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT ? "host" : "opaque-fd");
    return CV_OK;
}

static uint32_t pick_type(cv_backend_device *bd, uint32_t allowed, VkMemoryPropertyFlags preferred) {
    uint32_t fallback = UINT32_MAX;
    for (uint32_t i = 0; i < bd->memory.properties.memoryTypeCount; i++) {
        if (!(allowed & (1u << i)))
            continue;
        if ((bd->memory.properties.memoryTypes[i].propertyFlags & preferred) == preferred)
            return i;
        if (fallback == UINT32_MAX)
            fallback = i;
    }
    return fallback;
}

/* Creates the staging for d (not cached yet). On failure nothing is left and an
 * IMPORT's fd still belongs to the caller. */
static cv_result staging_create(cv_backend_device *bd, cv_staging_desc *d, vk_staging **out) {
    VkExternalMemoryHandleTypeFlagBits type = d->kind == CV_STAGING_HOST
                                                  ? VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT
                                                  : VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT;
    bool dedicated = false;
    cv_result r = check_external(bd, type, d->kind == CV_STAGING_EXPORT, &dedicated);
    if (r != CV_OK)
        return r;
    vk_staging *s = calloc(1, sizeof(*s));
    if (!s)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "device '%s': transfer staging record", bd->label);
    s->kind = d->kind;
    s->size = d->size;
    s->host = d->host;
    VkExternalMemoryBufferCreateInfo ext = { .sType = VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_BUFFER_CREATE_INFO,
                                             .handleTypes = type };
    VkBufferCreateInfo info = { .sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
                                .pNext = &ext,
                                .size = d->size,
                                .usage = usage,
                                .sharingMode = VK_SHARING_MODE_EXCLUSIVE };
    VkResult vr = vkCreateBuffer(bd->device, &info, NULL, &s->buffer);
    if (vr != VK_SUCCESS) {
        free(s);
        return vk_fail(vr, "vkCreateBuffer (transfer staging of %llu bytes, device '%s')",
                       (unsigned long long)d->size, bd->label);
    }
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(bd->device, s->buffer, &req);
    VkMemoryDedicatedAllocateInfo ded = { .sType = VK_STRUCTURE_TYPE_MEMORY_DEDICATED_ALLOCATE_INFO,
                                          .buffer = s->buffer };
    VkExportMemoryAllocateInfo exp = { .sType = VK_STRUCTURE_TYPE_EXPORT_MEMORY_ALLOCATE_INFO,
                                       .pNext = dedicated ? &ded : NULL,
                                       .handleTypes = type };
    VkImportMemoryFdInfoKHR imp_fd = { .sType = VK_STRUCTURE_TYPE_IMPORT_MEMORY_FD_INFO_KHR,
                                       .pNext = dedicated ? &ded : NULL,
                                       .handleType = type,
                                       .fd = d->fd };
    VkImportMemoryHostPointerInfoEXT imp_host = { .sType = VK_STRUCTURE_TYPE_IMPORT_MEMORY_HOST_POINTER_INFO_EXT,
                                                  .handleType = type,
                                                  .pHostPointer = d->host };
    VkMemoryAllocateInfo alloc = { .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, .allocationSize = req.size };
    uint32_t mem_type = UINT32_MAX;
    const char *why = "no memory type fits";
    if (d->kind == CV_STAGING_EXPORT) {
        alloc.pNext = &exp;
        mem_type = pick_type(bd, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    } else if (d->kind == CV_STAGING_IMPORT) {
        alloc.pNext = &imp_fd;
        alloc.allocationSize = d->allocation_size;
        mem_type = d->memory_type < 32 && (req.memoryTypeBits & (1u << d->memory_type)) &&
                           d->allocation_size >= req.size
                       ? d->memory_type
                       : UINT32_MAX;
        why = "the exported memory's type or size does not fit the buffer";
    } else {
        VkMemoryHostPointerPropertiesEXT hp = { .sType = VK_STRUCTURE_TYPE_MEMORY_HOST_POINTER_PROPERTIES_EXT };
        vr = bd->get_host_pointer_properties(bd->device, type, d->host, &hp);
        alloc.pNext = &imp_host;
        alloc.allocationSize = d->size;
        uint64_t align = bd->host_import_alignment ? bd->host_import_alignment : 1;
        if (vr == VK_SUCCESS && (uintptr_t)d->host % align == 0 && d->size % align == 0 && d->size >= req.size)
            mem_type = pick_type(bd, req.memoryTypeBits & hp.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
        why = "the host allocation cannot back the buffer (alignment, size or memory types)";
    }
    if (mem_type == UINT32_MAX) {
        vkDestroyBuffer(bd->device, s->buffer, NULL);
        free(s);
        return cv_error(CV_ERROR_UNSUPPORTED, "device '%s': transfer staging of %llu bytes: %s", bd->label,
                        (unsigned long long)d->size, why);
    }
    alloc.memoryTypeIndex = mem_type;
    vr = vkAllocateMemory(bd->device, &alloc, NULL, &s->memory);
    if (vr == VK_SUCCESS)
        vr = vkBindBufferMemory(bd->device, s->buffer, s->memory, 0);
    if (vr != VK_SUCCESS) {
        if (s->memory) /* an import that succeeded owns the fd: freeing the memory closes it */
            vkFreeMemory(bd->device, s->memory, NULL);
        vkDestroyBuffer(bd->device, s->buffer, NULL);
        bool fd_taken = s->memory && d->kind == CV_STAGING_IMPORT;
        free(s);
        if (fd_taken)
            d->fd = -1;
        return vk_fail(vr, "vkAllocateMemory/vkBindBufferMemory (transfer staging of %llu bytes, %s, device '%s')",
                       (unsigned long long)d->size,
                       d->kind == CV_STAGING_EXPORT   ? "exported"
                       : d->kind == CV_STAGING_IMPORT ? "imported fd"
                                                      : "imported host memory",
                       bd->label);
    }
    if (d->kind == CV_STAGING_IMPORT) {
        d->fd = -1; /* Vulkan owns it now */
        s->key = d->key;
    } else if (d->kind == CV_STAGING_EXPORT) {
        s->key = atomic_fetch_add(&next_key, 1);
        s->memory_type = mem_type;
        s->allocation_size = alloc.allocationSize;
    }
    *out = s;
    return CV_OK;
}

cv_result vk_link_staging(cv_backend_device *bd, cv_staging_desc *d, void **out) {
    if ((d->kind == CV_STAGING_HOST && !bd->external_host) || (d->kind != CV_STAGING_HOST && !bd->external_fd))
        return cv_error(CV_ERROR_UNSUPPORTED, "device '%s' lacks %s", bd->label,
                        d->kind == CV_STAGING_HOST ? VK_EXT_EXTERNAL_MEMORY_HOST_EXTENSION_NAME
                                                   : VK_KHR_EXTERNAL_MEMORY_FD_EXTENSION_NAME);
    vk_staging *s = d->owned ? NULL : cache_find(bd, d);
    /* An import of this device's own export is the export itself. */
    if (!s && !d->owned && d->kind == CV_STAGING_IMPORT)
        for (vk_staging *e = bd->links; e && !s; e = e->next)
            if (e->kind == CV_STAGING_EXPORT && e->key == d->key)
                s = e;
    bool created = false;
    if (!s) {
        cv_result r = staging_create(bd, d, &s);
        if (r != CV_OK)
            return r;
        created = true;
        s->owned = d->owned;
    }
    if (d->kind == CV_STAGING_EXPORT) {
        VkMemoryGetFdInfoKHR info = { .sType = VK_STRUCTURE_TYPE_MEMORY_GET_FD_INFO_KHR,
                                      .memory = s->memory,
                                      .handleType = VK_EXTERNAL_MEMORY_HANDLE_TYPE_OPAQUE_FD_BIT };
        int fd = -1;
        VkResult vr = bd->get_memory_fd(bd->device, &info, &fd);
        if (vr != VK_SUCCESS) {
            if (created)
                staging_free(bd, s);
            return vk_fail(vr, "vkGetMemoryFdKHR (transfer staging, device '%s')", bd->label);
        }
        d->fd = fd;
        d->key = s->key;
        d->memory_type = s->memory_type;
        d->allocation_size = s->allocation_size;
    }
    if (created && s->owned) {
        s->next = bd->links;
        bd->links = s;
    } else if (created) {
        cache_add(bd, s);
    }
    *out = s;
    return CV_OK;
}

/* Ownership of opaque-fd memory between this device and the others. */
static void external_barrier(VkCommandBuffer cmd, uint32_t family, VkBuffer buffer, bool acquire) {
    VkBufferMemoryBarrier2 b = {
        .sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2,
        .srcStageMask = acquire ? VK_PIPELINE_STAGE_2_NONE : VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
        .srcAccessMask = acquire ? 0 : VK_ACCESS_2_TRANSFER_WRITE_BIT,
        .dstStageMask = acquire ? VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT : VK_PIPELINE_STAGE_2_NONE,
        .dstAccessMask = acquire ? VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT : 0,
        .srcQueueFamilyIndex = acquire ? VK_QUEUE_FAMILY_EXTERNAL : family,
        .dstQueueFamilyIndex = acquire ? family : VK_QUEUE_FAMILY_EXTERNAL,
        .buffer = buffer,
        .offset = 0,
        .size = VK_WHOLE_SIZE,
    };
    VkDependencyInfo dep = { .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
                             .bufferMemoryBarrierCount = 1,
                             .pBufferMemoryBarriers = &b };
    vkCmdPipelineBarrier2(cmd, &dep);
}

void vk_link_record(const cv_backend_device *bd, VkCommandBuffer cmd, vk_queue_slot slot, void *staging,
                    uint64_t staging_offset, cv_handle_type type, void *obj, uint64_t offset, uint64_t size,
                    cv_rect rect, bool to_staging) {
    vk_staging *s = staging;
    bool external = s->kind != CV_STAGING_HOST;
    uint32_t family = bd->queues[slot].family;
    if (external)
        external_barrier(cmd, family, s->buffer, true);
    if (type == CV_HANDLE_TEXTURE) {
        vk_record_texture_rows(cmd, obj, s->buffer, staging_offset, rect, !to_staging);
    } else {
        vk_buffer *b = obj;
        VkBufferCopy region = to_staging ? (VkBufferCopy){ offset, staging_offset, size }
                                         : (VkBufferCopy){ staging_offset, offset, size };
        vkCmdCopyBuffer(cmd, to_staging ? b->buffer : s->buffer, to_staging ? s->buffer : b->buffer, 1, &region);
    }
    if (external)
        external_barrier(cmd, family, s->buffer, false);
}

cv_result vk_link_in_range(const cv_backend_device *bd, void *staging, uint64_t staging_offset, cv_handle_type type,
                           void *obj, uint64_t size, cv_rect rect) {
    vk_staging *s = staging;
    if (type == CV_HANDLE_TEXTURE)
        size = (uint64_t)rect.width * rect.height * ((vk_texture *)obj)->texel_bytes;
    if (staging_offset <= s->size && size <= s->size - staging_offset)
        return CV_OK;
    return cv_error(CV_ERROR_OUT_OF_RANGE, "device '%s': %llu bytes at %llu of a %llu-byte transfer staging",
                    bd->label, (unsigned long long)size, (unsigned long long)staging_offset,
                    (unsigned long long)s->size);
}

cv_result vk_link_copy(cv_backend_device *bd, void *staging, uint64_t staging_offset, cv_handle_type type, void *obj,
                       uint64_t offset, uint64_t size, cv_rect rect, bool to_staging) {
    cv_result r = vk_link_in_range(bd, staging, staging_offset, type, obj, size, rect);
    VkCommandBuffer cmd;
    if (r == CV_OK)
        r = vk_immediate_begin(bd, &cmd);
    if (r != CV_OK)
        return r;
    vk_link_record(bd, cmd, VK_SLOT_GRAPHICS, staging, staging_offset, type, obj, offset, size, rect, to_staging);
    return vk_immediate_end(bd);
}

void vk_link_release(cv_backend_device *bd, void *staging) {
    for (vk_staging **link = &bd->links; *link; link = &(*link)->next)
        if (*link == staging) {
            *link = ((vk_staging *)staging)->next;
            staging_free(bd, staging);
            return;
        }
}
