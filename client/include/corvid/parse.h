/* Whole numbers typed by people: every program option and environment
 * variable that takes a count, a size or a time in milliseconds is parsed here,
 * one strict way, so that no program accepts what another refuses. The library
 * parses text it is given; reading the environment is the program's (apps/common/).
 *
 * Accepted: plain decimal digits, nothing else ("12"). Refused: a sign ("+2",
 * "-1": strtoul takes both, the second as 2^64-1), blanks (" 2"), hex ("0x10"),
 * anything after the digits ("2abc", "2 "), the empty string, and a value
 * outside min..max. (atoi read "abc" as 0, which then meant "the default".)
 *
 *   uint64_t n;
 *   if (!cv_parse_uint(text, 1, 64, &n))               // a program's own message
 *       fprintf(stderr, "prog: --gpus: '%s' is not a whole number in 1..64\n", text);
 *   // text as a program read it (an option's value, or an environment variable in apps/common/)
 *   cv_result r = cv_parse_uint_named("CORVID_NODE_TIMEOUT_MS", text, 1, 86400000, &n);
 *   // CV_ERROR_INVALID_ARGUMENT naming the variable
 *
 * Words from a fixed list, the same strict way (exact, case-sensitive):
 *
 *   static const char *const words[] = { "auto", "bridge", "import" };
 *   uint32_t k;
 *   cv_result r = cv_parse_word_named("CORVID_CROSS_WAIT", text, words, 3, &k);
 *   // "x": CV_ERROR_INVALID_ARGUMENT, "CORVID_CROSS_WAIT='x': expected auto, bridge or import"
 */
#ifndef CORVID_PARSE_H
#define CORVID_PARSE_H

#include <stdbool.h>
#include <stdint.h>

#include "corvid/result.h"

/* *out = the number `text` writes, if it is plain decimal digits within
 * min..max; otherwise false and *out unchanged. NULL text is false. */
bool cv_parse_uint(const char *text, uint64_t min, uint64_t max, uint64_t *out);

/* cv_parse_uint, failing with CV_ERROR_INVALID_ARGUMENT
 * "<what>: '<text>' is not a whole number in <min>..<max>" (text cut to 64
 * characters in the message). */
cv_result cv_parse_uint_named(const char *what, const char *text, uint64_t min, uint64_t max, uint64_t *out);
/* *index = the position of `text` among `words`; otherwise (NULL text too)
 * CV_ERROR_INVALID_ARGUMENT "<what>='<text>': expected <w0>, <w1> or <w2>"
 * (text cut to 32 characters) and *index unchanged. */
cv_result cv_parse_word_named(const char *what, const char *text, const char *const *words, uint32_t count,
                              uint32_t *index);

#endif
