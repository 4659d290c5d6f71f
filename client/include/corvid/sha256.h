/* SHA-256 digests, as the client and the node both compute them: the client
 * hashes what it is about to upload, the node's content store checks that an
 * upload's bytes match the hash it was keyed by.
 *
 * Backed by OpenSSL's libcrypto (EVP), which uses the CPU's SHA instructions
 * where there are any. One-shot:
 *
 *     uint8_t sha[32];
 *     cv_sha256(data, size, sha);
 *
 * or incrementally, over data that arrives in pieces:
 *
 *     cv_sha256_ctx ctx;
 *     if (cv_sha256_init(&ctx) != CV_OK) ...;
 *     cv_sha256_update(&ctx, piece, piece_size);   (any number of times)
 *     cv_result r = cv_sha256_final(&ctx, sha);     (frees the context either way)
 *
 * A context that is abandoned instead of finished is freed with
 * cv_sha256_discard(). Digests print as 64 lowercase hex digits. */
#ifndef CORVID_SHA256_H
#define CORVID_SHA256_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "corvid/result.h"

#define CV_SHA256_SIZE 32
#define CV_SHA256_HEX_SIZE 65 /* 64 digits and the terminating NUL */

typedef struct cv_sha256_ctx {
    void *evp;   /* the EVP_MD_CTX; NULL once finished or discarded */
    bool failed; /* an update failed: final reports it */
} cv_sha256_ctx;

/* The digest of `size` bytes. CV_ERROR_OUT_OF_MEMORY or CV_ERROR_BACKEND
 * (libcrypto failed) leave `out` unspecified. */
cv_result cv_sha256(const void *data, size_t size, uint8_t out[CV_SHA256_SIZE]);

cv_result cv_sha256_init(cv_sha256_ctx *ctx);
void cv_sha256_update(cv_sha256_ctx *ctx, const void *data, size_t size);
/* Writes the digest of everything passed to update and frees the context,
 * also when it fails (CV_ERROR_BACKEND: libcrypto reported an error). */
cv_result cv_sha256_final(cv_sha256_ctx *ctx, uint8_t out[CV_SHA256_SIZE]);
void cv_sha256_discard(cv_sha256_ctx *ctx);

/* 64 lowercase hex digits and a NUL. */
void cv_sha256_hex(const uint8_t sha[CV_SHA256_SIZE], char out[CV_SHA256_HEX_SIZE]);
/* Parses exactly 64 hex digits (either case) followed by the end of the
 * string; false (and `out` unchanged) for anything else. */
bool cv_sha256_parse_hex(const char *hex, uint8_t out[CV_SHA256_SIZE]);

#endif
