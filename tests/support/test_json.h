/* Reading JSON files back in tests (cJSON): a whole file parsed, and a
 * member's number. What render_log_test.c and render_outputs_test.c each
 * defined as their own parse_file() and number().
 *
 *     cJSON *root = cv_test_json_parse_file("stats.json");
 *     CHECK(root != NULL);
 *     const cJSON *summary = cJSON_GetObjectItemCaseSensitive(root, "summary");
 *     CHECK_EQ_INT(cv_test_json_number(summary, "rays_total"), 5760);
 *     cJSON_Delete(root);
 */
#ifndef CORVID_TEST_JSON_H
#define CORVID_TEST_JSON_H

#include <cjson/cJSON.h>

/* The file at `path` parsed (up to 4 MiB read); NULL if it cannot be read or
 * is not JSON. The caller frees it with cJSON_Delete. */
cJSON *cv_test_json_parse_file(const char *path);

/* o's member `key` as a number; NAN if o is NULL, or the member is missing or
 * not a number. */
double cv_test_json_number(const cJSON *o, const char *key);

#endif
