/* One word from a fixed list (vk_env.h). */
#include "vk_env.h"

#include <stdio.h>
#include <string.h>

cv_result vk_env_choice(const char *name, const char *value, const char *const *words, uint32_t count,
                        uint32_t *index) {
    *index = 0;
    if (!value || !value[0])
        return CV_OK;
    for (uint32_t k = 0; k < count; k++)
        if (strcmp(value, words[k]) == 0) {
            *index = k;
            return CV_OK;
        }
    char expected[256] = "";
    size_t used = 0;
    for (uint32_t k = 0; k < count && used < sizeof(expected); k++)
        used += (size_t)snprintf(expected + used, sizeof(expected) - used, "%s%s",
                                 k == 0           ? ""
                                 : k + 1 == count ? " or "
                                                  : ", ",
                                 words[k]);
    return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s='%.32s': expected %s", name, value, expected);
}
