/* Block sub-allocator for device memory.
 *
 * Each (memory type, linear/optimal) pair has a list of blocks; a block keeps
 * its free ranges sorted by offset and allocates first-fit, merging neighbours
 * on free. Requests larger than half a block get a block of their own. One
 * empty block per list is kept for reuse, so creating and destroying resources
 * in a loop does not call vkAllocateMemory each time; other empty blocks are
 * freed at once. Host-visible blocks are mapped once, for their lifetime.
 * Where the device imports host memory (vk_memory.h), blocks are fresh
 * anonymous mappings of our own. */
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "vk_memory.h"

#define DEFAULT_BLOCK_SIZE (64ull << 20)

typedef struct free_range {
    VkDeviceSize offset, size;
} free_range;

struct vk_block {
    vk_block *next;
    VkDeviceMemory memory;
    VkDeviceSize size;
    uint32_t type;
    void *mapped;
    void *host;              /* an imported anonymous mapping of our own (munmapped with the block), or NULL */
    VkDeviceSize clean_from; /* host: ranges at or above it were never handed out (zero pages) */
    bool dedicated;
    uint32_t live; /* allocations in this block */
    free_range *ranges;
    uint32_t range_count, range_capacity;
};

/* process-wide: cv_vulkan_live_memory_blocks counts the VkDeviceMemory blocks
 * of every device, so leak checks see what a destroyed device left. */
static atomic_uint live_blocks;

uint32_t cv_vulkan_live_memory_blocks(void) { return atomic_load(&live_blocks); }

void vk_memory_init(vk_memory *m, VkDevice device, VkPhysicalDevice physical) {
    memset(m, 0, sizeof(*m));
    m->device = device;
    vkGetPhysicalDeviceMemoryProperties(physical, &m->properties);
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(physical, &props);
    m->atom = props.limits.nonCoherentAtomSize ? props.limits.nonCoherentAtomSize : 1;
    m->block_size = DEFAULT_BLOCK_SIZE;
    pthread_mutex_init(&m->lock, NULL);
}

static void block_destroy(vk_memory *m, vk_block *b) {
    if (b->mapped && !b->host)
        vkUnmapMemory(m->device, b->memory);
    vkFreeMemory(m->device, b->memory, NULL);
    if (b->host)
        munmap(b->host, b->size);
    atomic_fetch_sub(&live_blocks, 1u);
    m->block_count--;
    m->block_bytes -= b->size;
    free(b->ranges);
    free(b);
}

void vk_memory_finish(vk_memory *m) {
    for (uint32_t t = 0; t < VK_MAX_MEMORY_TYPES; t++)
        for (int k = 0; k < 2; k++)
            while (m->blocks[t][k]) {
                vk_block *b = m->blocks[t][k];
                m->blocks[t][k] = b->next;
                block_destroy(m, b);
            }
    pthread_mutex_destroy(&m->lock);
}

bool vk_memory_enable_host_import(vk_memory *m, PFN_vkGetMemoryHostPointerPropertiesEXT properties,
                                  VkDeviceSize alignment) {
    long page = sysconf(_SC_PAGESIZE);
    if (!properties || !alignment || (alignment & (alignment - 1)) || page <= 0 || alignment > (VkDeviceSize)page)
        return false;
    void *probe = mmap(NULL, (size_t)page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (probe == MAP_FAILED)
        return false;
    VkMemoryHostPointerPropertiesEXT host = { .sType = VK_STRUCTURE_TYPE_MEMORY_HOST_POINTER_PROPERTIES_EXT };
    VkResult vr = properties(m->device, VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT, probe, &host);
    munmap(probe, (size_t)page);
    const VkMemoryPropertyFlags own = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT;
    uint32_t types = 0;
    for (uint32_t i = 0; vr == VK_SUCCESS && i < m->properties.memoryTypeCount; i++)
        if ((host.memoryTypeBits & (1u << i)) && (m->properties.memoryTypes[i].propertyFlags & own) == own)
            types |= 1u << i;
    m->host_import_types = types;
    m->host_import_alignment = alignment;
    m->host_pointer_properties = properties;
    return types != 0;
}

static const VkExternalMemoryBufferCreateInfo host_buffer = {
    .sType = VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_BUFFER_CREATE_INFO,
    .handleTypes = VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT
};
static const VkExternalMemoryImageCreateInfo host_image = {
    .sType = VK_STRUCTURE_TYPE_EXTERNAL_MEMORY_IMAGE_CREATE_INFO,
    .handleTypes = VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT
};

const void *vk_memory_buffer_external(const vk_memory *m) { return m->host_import_types ? &host_buffer : NULL; }
const void *vk_memory_image_external(const vk_memory *m) { return m->host_import_types ? &host_image : NULL; }

/* Best memory type for the request, or UINT32_MAX. */
static uint32_t choose_type(const vk_memory *m, uint32_t allowed, VkMemoryPropertyFlags required,
                            VkMemoryPropertyFlags preferred) {
    uint32_t best = UINT32_MAX;
    int best_score = -1;
    for (uint32_t i = 0; i < m->properties.memoryTypeCount; i++) {
        VkMemoryPropertyFlags f = m->properties.memoryTypes[i].propertyFlags;
        if (!(allowed & (1u << i)) || (f & required) != required)
            continue;
        int score = 0;
        if ((f & preferred) == preferred)
            score += 2;
        if (!(f & ~(required | preferred)))
            score += 1;
        if (score > best_score) {
            best_score = score;
            best = i;
        }
    }
    return best;
}

static VkDeviceSize align_up(VkDeviceSize v, VkDeviceSize a) { return (v + a - 1) / a * a; }

/* Maps `size` bytes of fresh anonymous memory and imports them as b's memory
 * (vk_memory_enable_host_import); false, holding nothing, where the type is
 * not imported or the import fails (the caller allocates as usual). */
static bool import_host_block(vk_memory *m, uint32_t type, const void *next, VkDeviceSize size, vk_block *b) {
    if (!(m->host_import_types & (1u << type)))
        return false;
    void *host = mmap(NULL, size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (host == MAP_FAILED)
        return false;
    VkImportMemoryHostPointerInfoEXT import = { .sType = VK_STRUCTURE_TYPE_IMPORT_MEMORY_HOST_POINTER_INFO_EXT,
                                                .pNext = next,
                                                .handleType = VK_EXTERNAL_MEMORY_HANDLE_TYPE_HOST_ALLOCATION_BIT_EXT,
                                                .pHostPointer = host };
    VkMemoryAllocateInfo info = { .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
                                  .pNext = &import,
                                  .allocationSize = size,
                                  .memoryTypeIndex = type };
    if (vkAllocateMemory(m->device, &info, NULL, &b->memory) != VK_SUCCESS) {
        munmap(host, size);
        return false;
    }
    b->host = b->mapped = host;
    b->clean_from = 0;
    return true;
}

/* b's memory from the driver, mapped if host-visible. */
static cv_result allocate_block(vk_memory *m, uint32_t type, const void *next, VkDeviceSize size, bool dedicated,
                                const char *what, vk_block *b) {
    VkMemoryAllocateInfo info = { .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
                                  .pNext = next,
                                  .allocationSize = size,
                                  .memoryTypeIndex = type };
    VkResult vr = vkAllocateMemory(m->device, &info, NULL, &b->memory);
    if (vr != VK_SUCCESS) {
        uint32_t heap = m->properties.memoryTypes[type].heapIndex;
        return vk_fail(vr,
                       "vkAllocateMemory of %llu bytes (%s) for %s from heap %u of %llu bytes (memory type %u, "
                       "%llu bytes already allocated on this device)",
                       (unsigned long long)size, dedicated ? "a dedicated allocation" : "a shared block", what, heap,
                       (unsigned long long)m->properties.memoryHeaps[heap].size, type,
                       (unsigned long long)m->block_bytes);
    }
    b->clean_from = size; /* what the driver hands out may hold anything */
    if (m->properties.memoryTypes[type].propertyFlags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) {
        vr = vkMapMemory(m->device, b->memory, 0, VK_WHOLE_SIZE, 0, &b->mapped);
        if (vr != VK_SUCCESS) {
            vkFreeMemory(m->device, b->memory, NULL);
            return vk_fail(vr, "vkMapMemory of a %llu-byte block for %s", (unsigned long long)size, what);
        }
    }
    return CV_OK;
}

static cv_result block_create(vk_memory *m, uint32_t type, vk_memory_kind kind, VkDeviceSize size, bool dedicated,
                              const char *what, vk_block **out) {
    vk_block *b = calloc(1, sizeof(*b));
    free_range *ranges = malloc(4 * sizeof(*ranges));
    if (!b || !ranges) {
        free(b);
        free(ranges);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "vulkan: host memory for the record of a %llu-byte block for %s",
                        (unsigned long long)size, what);
    }
    /* Buffers in linear blocks may be read through device addresses (trace kernels, acceleration structures). */
    VkMemoryAllocateFlagsInfo flags = { .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO,
                                        .flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT };
    const void *next = m->device_address && kind == VK_MEMORY_LINEAR ? &flags : NULL;
    if (m->host_import_types & (1u << type))
        size = align_up(size, m->host_import_alignment);
    cv_result r = CV_OK;
    if (!import_host_block(m, type, next, size, b))
        r = allocate_block(m, type, next, size, dedicated, what, b);
    if (r != CV_OK) {
        free(ranges);
        free(b);
        return r;
    }
    b->ranges = ranges;
    b->ranges[0] = (free_range){ 0, size };
    b->range_count = 1;
    b->range_capacity = 4;
    b->size = size;
    b->type = type;
    b->dedicated = dedicated;
    atomic_fetch_add(&live_blocks, 1u);
    m->block_count++;
    m->block_bytes += size;
    *out = b;
    return CV_OK;
}

/* First fit within one block; false if it does not fit. */
static bool block_take(vk_block *b, VkDeviceSize size, VkDeviceSize alignment, VkDeviceSize *offset) {
    for (uint32_t i = 0; i < b->range_count; i++) {
        free_range *r = &b->ranges[i];
        VkDeviceSize start = align_up(r->offset, alignment);
        if (start + size > r->offset + r->size)
            continue;
        VkDeviceSize head = start - r->offset, tail = r->offset + r->size - (start + size);
        if (head && tail) {
            if (b->range_count == b->range_capacity) {
                free_range *grown = realloc(b->ranges, 2 * b->range_capacity * sizeof(*grown));
                if (!grown)
                    return false;
                b->ranges = grown;
                b->range_capacity *= 2;
                r = &b->ranges[i];
            }
            memmove(&b->ranges[i + 2], &b->ranges[i + 1], (b->range_count - i - 1) * sizeof(*r));
            b->ranges[i + 1] = (free_range){ start + size, tail };
            r->size = head;
            b->range_count++;
        } else if (head) {
            r->size = head;
        } else if (tail) {
            *r = (free_range){ start + size, tail };
        } else {
            memmove(r, r + 1, (b->range_count - i - 1) * sizeof(*r));
            b->range_count--;
        }
        *offset = start;
        return true;
    }
    return false;
}

/* Returns [offset, offset+size) to the block, merging with neighbours. */
static void block_give(vk_block *b, VkDeviceSize offset, VkDeviceSize size) {
    uint32_t i = 0;
    while (i < b->range_count && b->ranges[i].offset < offset)
        i++;
    bool join_prev = i > 0 && b->ranges[i - 1].offset + b->ranges[i - 1].size == offset;
    bool join_next = i < b->range_count && offset + size == b->ranges[i].offset;
    if (join_prev && join_next) {
        b->ranges[i - 1].size += size + b->ranges[i].size;
        memmove(&b->ranges[i], &b->ranges[i + 1], (b->range_count - i - 1) * sizeof(free_range));
        b->range_count--;
    } else if (join_prev) {
        b->ranges[i - 1].size += size;
    } else if (join_next) {
        b->ranges[i].offset = offset;
        b->ranges[i].size += size;
    } else {
        if (b->range_count == b->range_capacity) {
            /* Cannot grow: the range stays lost until the block is freed, which
             * is safe; it only happens when the host is out of memory. */
            free_range *grown = realloc(b->ranges, 2 * b->range_capacity * sizeof(free_range));
            if (!grown)
                return;
            b->ranges = grown;
            b->range_capacity *= 2;
        }
        memmove(&b->ranges[i + 1], &b->ranges[i], (b->range_count - i) * sizeof(free_range));
        b->ranges[i] = (free_range){ offset, size };
        b->range_count++;
    }
}

cv_result vk_memory_alloc(vk_memory *m, const VkMemoryRequirements *req, VkMemoryPropertyFlags required,
                          VkMemoryPropertyFlags preferred, vk_memory_kind kind, const char *what,
                          vk_allocation *out) {
    uint32_t type = choose_type(m, req->memoryTypeBits, required, preferred);
    if (type == UINT32_MAX)
        return cv_error(CV_ERROR_UNSUPPORTED, "vulkan: no memory type with flags 0x%x for %s (allowed types 0x%x)",
                        required, what, req->memoryTypeBits);
    VkDeviceSize alignment = req->alignment ? req->alignment : 1;
    bool dedicated = req->size > m->block_size / 2;
    pthread_mutex_lock(&m->lock);
    vk_block *block = NULL;
    VkDeviceSize offset = 0;
    if (!dedicated)
        for (block = m->blocks[type][kind]; block; block = block->next)
            if (!block->dedicated && block_take(block, req->size, alignment, &offset))
                break;
    cv_result r = CV_OK;
    if (!block) {
        r = block_create(m, type, kind, dedicated ? req->size : m->block_size, dedicated, what, &block);
        if (r == CV_OK && !block_take(block, req->size, alignment, &offset)) {
            block_destroy(m, block);
            r = cv_error(CV_ERROR_OUT_OF_MEMORY,
                         "vulkan: %llu bytes (alignment %llu) for %s do not fit a new block "
                         "of memory type %u (heap %u)",
                         (unsigned long long)req->size, (unsigned long long)alignment, what, type,
                         m->properties.memoryTypes[type].heapIndex);
        }
        if (r == CV_OK) {
            block->next = m->blocks[type][kind];
            m->blocks[type][kind] = block;
        }
    }
    if (r == CV_OK) {
        block->live++;
        m->allocation_count++;
        m->allocated_bytes += req->size;
        VkMemoryPropertyFlags flags = m->properties.memoryTypes[type].propertyFlags;
        *out = (vk_allocation){
            .block = block,
            .memory = block->memory,
            .offset = offset,
            .size = req->size,
            .mapped = block->mapped ? (char *)block->mapped + offset : NULL,
            .coherent = flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
            .zeroed = offset >= block->clean_from,
        };
        if (block->clean_from < offset + req->size)
            block->clean_from = offset + req->size;
    }
    pthread_mutex_unlock(&m->lock);
    return r;
}

/* Whether another empty shared block is already in the list (then b can go). */
static bool has_other_empty(const vk_block *list, const vk_block *b) {
    for (const vk_block *o = list; o; o = o->next)
        if (o != b && !o->dedicated && o->live == 0)
            return true;
    return false;
}

void vk_memory_free(vk_memory *m, vk_allocation *a) {
    vk_block *b = a->block;
    if (!b)
        return;
    pthread_mutex_lock(&m->lock);
    block_give(b, a->offset, a->size);
    b->live--;
    m->allocation_count--;
    m->allocated_bytes -= a->size;
    if (b->live == 0) {
        for (int k = 0; k < 2; k++) {
            vk_block **link = &m->blocks[b->type][k];
            while (*link && *link != b)
                link = &(*link)->next;
            if (*link && (b->dedicated || has_other_empty(m->blocks[b->type][k], b))) {
                *link = b->next;
                block_destroy(m, b);
                break;
            }
        }
    }
    pthread_mutex_unlock(&m->lock);
    memset(a, 0, sizeof(*a));
}

/* The atom-aligned range of a mapping that covers [offset, offset+size) of a. */
static VkMappedMemoryRange mapped_range(const vk_memory *m, const vk_allocation *a, VkDeviceSize offset,
                                        VkDeviceSize size) {
    VkDeviceSize start = (a->offset + offset) / m->atom * m->atom;
    VkDeviceSize end = align_up(a->offset + offset + size, m->atom);
    if (end > a->block->size)
        end = a->block->size;
    return (VkMappedMemoryRange){
        .sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE, .memory = a->memory, .offset = start, .size = end - start
    };
}

void vk_memory_flush(vk_memory *m, const vk_allocation *a, VkDeviceSize offset, VkDeviceSize size) {
    if (a->coherent)
        return;
    VkMappedMemoryRange range = mapped_range(m, a, offset, size);
    vkFlushMappedMemoryRanges(m->device, 1, &range);
}

void vk_memory_invalidate(vk_memory *m, const vk_allocation *a, VkDeviceSize offset, VkDeviceSize size) {
    if (a->coherent)
        return;
    VkMappedMemoryRange range = mapped_range(m, a, offset, size);
    vkInvalidateMappedMemoryRanges(m->device, 1, &range);
}

void vk_memory_stats(vk_memory *m, cv_vulkan_memory_stats *out) {
    pthread_mutex_lock(&m->lock);
    out->block_count = m->block_count;
    out->block_bytes = m->block_bytes;
    out->allocation_count = m->allocation_count;
    out->allocated_bytes = m->allocated_bytes;
    pthread_mutex_unlock(&m->lock);
}
