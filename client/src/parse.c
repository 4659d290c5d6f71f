/* See corvid/parse.h. */
#include "corvid/parse.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

bool cv_parse_uint(const char *text, uint64_t min, uint64_t max, uint64_t *out) {
    if (!text || text[0] < '0' || text[0] > '9' || strspn(text, "0123456789") != strlen(text))
        return false;
    errno = 0;
    unsigned long long v = strtoull(text, NULL, 10);
    if (errno || v < min || v > max)
        return false;
    *out = v;
    return true;
}

cv_result cv_parse_uint_named(const char *what, const char *text, uint64_t min, uint64_t max, uint64_t *out) {
    if (cv_parse_uint(text, min, max, out))
        return CV_OK;
    return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: '%.64s%s' is not a whole number in %llu..%llu", what,
                    text ? text : "", text && strlen(text) > 64 ? "..." : "", (unsigned long long)min,
                    (unsigned long long)max);
}

cv_result cv_parse_word_named(const char *what, const char *text, const char *const *words, uint32_t count,
                              uint32_t *index) {
    for (uint32_t k = 0; text && k < count; k++)
        if (strcmp(text, words[k]) == 0) {
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
    return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s='%.32s': expected %s", what, text ? text : "", expected);
}
