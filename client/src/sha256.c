/* SHA-256 on OpenSSL's EVP interface (see sha256.h). */
#include "corvid/sha256.h"

#include <openssl/evp.h>
#include <pthread.h>

/* process-wide: OpenSSL 3 looks the algorithm up in its provider tables on
 * every init that names it through EVP_sha256(); fetching it once for the
 * process (it is immutable and thread-safe) keeps that off each upload. */
static EVP_MD *sha256_md;
static pthread_once_t sha256_once = PTHREAD_ONCE_INIT;

static void fetch_md(void) { sha256_md = EVP_MD_fetch(NULL, "SHA256", NULL); }

static const EVP_MD *md(void) {
    pthread_once(&sha256_once, fetch_md);
    return sha256_md ? sha256_md : EVP_sha256();
}

cv_result cv_sha256(const void *data, size_t size, uint8_t out[CV_SHA256_SIZE]) {
    cv_sha256_ctx ctx;
    cv_result r = cv_sha256_init(&ctx);
    if (r != CV_OK)
        return r;
    cv_sha256_update(&ctx, data, size);
    return cv_sha256_final(&ctx, out);
}

cv_result cv_sha256_init(cv_sha256_ctx *ctx) {
    *ctx = (cv_sha256_ctx){ 0 }; /* written on failure too: a discard after it is harmless */
    EVP_MD_CTX *evp = EVP_MD_CTX_new();
    if (evp == NULL)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "sha256: EVP_MD_CTX_new failed");
    if (EVP_DigestInit_ex(evp, md(), NULL) != 1) {
        EVP_MD_CTX_free(evp);
        return cv_error(CV_ERROR_BACKEND, "sha256: EVP_DigestInit_ex failed");
    }
    *ctx = (cv_sha256_ctx){ .evp = evp };
    return CV_OK;
}

void cv_sha256_update(cv_sha256_ctx *ctx, const void *data, size_t size) {
    if (size > 0 && !ctx->failed && EVP_DigestUpdate(ctx->evp, data, size) != 1)
        ctx->failed = true;
}

cv_result cv_sha256_final(cv_sha256_ctx *ctx, uint8_t out[CV_SHA256_SIZE]) {
    unsigned int n = 0;
    bool ok = !ctx->failed && EVP_DigestFinal_ex(ctx->evp, out, &n) == 1 && n == CV_SHA256_SIZE;
    cv_sha256_discard(ctx);
    return ok ? CV_OK : cv_error(CV_ERROR_BACKEND, "sha256: libcrypto failed to compute the digest");
}

void cv_sha256_discard(cv_sha256_ctx *ctx) {
    EVP_MD_CTX_free(ctx->evp);
    ctx->evp = NULL;
    ctx->failed = false;
}

void cv_sha256_hex(const uint8_t sha[CV_SHA256_SIZE], char out[CV_SHA256_HEX_SIZE]) {
    static const char digits[] = "0123456789abcdef";
    for (int i = 0; i < CV_SHA256_SIZE; i++) {
        out[2 * i] = digits[sha[i] >> 4];
        out[2 * i + 1] = digits[sha[i] & 15];
    }
    out[2 * CV_SHA256_SIZE] = '\0';
}

static int hex_value(char c) {
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

bool cv_sha256_parse_hex(const char *hex, uint8_t out[CV_SHA256_SIZE]) {
    uint8_t sha[CV_SHA256_SIZE];
    for (int i = 0; i < CV_SHA256_SIZE; i++) {
        int hi = hex_value(hex[2 * i]);
        int lo = hi < 0 ? -1 : hex_value(hex[2 * i + 1]);
        if (lo < 0)
            return false;
        sha[i] = (uint8_t)(hi << 4 | lo);
    }
    if (hex[2 * CV_SHA256_SIZE] != '\0')
        return false;
    for (int i = 0; i < CV_SHA256_SIZE; i++)
        out[i] = sha[i];
    return true;
}
