/* The fixture table. The Vulkan fixture exists when the Vulkan backend is built. */
#include "fixture.h"

#include <stdio.h>
#include <string.h>

#ifdef CORVID_HAVE_VULKAN
#include "corvid/vulkan.h"
#endif

static const fixture fixtures[] = {
    { .name = "mock", .backend = cv_mock_backend, .max_devices = 4 },
#ifdef CORVID_HAVE_VULKAN
    { .name = "vulkan", .backend = cv_vulkan_backend, .max_devices = 3,
      .validation_messages = cv_vulkan_validation_message_count, .executes_shaders = true },
#endif
};

const fixture *fixture_find(const char *name) {
    for (size_t i = 0; i < sizeof(fixtures) / sizeof(fixtures[0]); i++)
        if (strcmp(fixtures[i].name, name) == 0)
            return &fixtures[i];
    return NULL;
}

cv_result fixture_device(const fixture *f, cv_context *ctx, uint32_t index, cv_device **out) {
    cv_device_desc desc = { .validation = true };
    snprintf(desc.label, sizeof(desc.label), "%s%u", f->name, index);
    return cv_device_create(ctx, f->backend(), &desc, out);
}
