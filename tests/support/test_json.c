/* See test_json.h. */
#include "test_json.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#define MAX_JSON_BYTES (4u << 20)

cJSON *cv_test_json_parse_file(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    char *text = malloc(MAX_JSON_BYTES + 1);
    size_t n = text ? fread(text, 1, MAX_JSON_BYTES, f) : 0;
    fclose(f);
    if (!text)
        return NULL;
    text[n] = 0;
    cJSON *root = cJSON_Parse(text);
    free(text);
    return root;
}

double cv_test_json_number(const cJSON *o, const char *key) {
    const cJSON *v = o ? cJSON_GetObjectItemCaseSensitive(o, key) : NULL;
    return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}
