/* cv_sha256: the FIPS 180-2 test vectors one-shot and incrementally, and the
 * hex conversions. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/sha256.h"

static void check_digest(const uint8_t sha[32], const char *expected) {
    char hex[CV_SHA256_HEX_SIZE];
    cv_sha256_hex(sha, hex);
    CHECK(strcmp(hex, expected) == 0);
    if (strcmp(hex, expected) != 0)
        fprintf(stderr, "  got %s\n  expected %s\n", hex, expected);
}

static void one_shot_vectors(void) {
    static const struct {
        const char *message, *digest;
    } vectors[] = {
        { "abc", "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad" },
        { "", "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855" },
        { "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq",
          "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1" },
    };
    for (size_t i = 0; i < sizeof vectors / sizeof vectors[0]; i++) {
        uint8_t sha[32];
        CHECK_OK(cv_sha256(vectors[i].message, strlen(vectors[i].message), sha));
        check_digest(sha, vectors[i].digest);
    }
}

/* One million 'a' in pieces of 1, 2, 3, ... 997 bytes, wrapping around: the
 * pieces straddle the 64-byte block boundaries in every way. */
static void million_a_incrementally(void) {
    enum { TOTAL = 1000000 };
    char *a = malloc(1000);
    memset(a, 'a', 1000);
    cv_sha256_ctx ctx;
    CHECK_OK(cv_sha256_init(&ctx));
    size_t done = 0, piece = 1;
    while (done < TOTAL) {
        size_t n = piece < TOTAL - done ? piece : TOTAL - done;
        cv_sha256_update(&ctx, a, n);
        done += n;
        piece = piece % 997 + 1;
    }
    uint8_t sha[32];
    CHECK_OK(cv_sha256_final(&ctx, sha));
    CHECK(ctx.evp == NULL);
    check_digest(sha, "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
    free(a);

    /* Abandoned contexts are freed by discard (ASan checks that). */
    CHECK_OK(cv_sha256_init(&ctx));
    cv_sha256_update(&ctx, "abc", 3);
    cv_sha256_discard(&ctx);
    CHECK(ctx.evp == NULL);
}

static void hex_round_trip(void) {
    const char *hex = "BA7816BF8F01CFEA414140DE5DAE2223B00361A396177A9CB410FF61F20015AD";
    uint8_t sha[32], expected[32];
    CHECK_OK(cv_sha256("abc", 3, expected));
    CHECK(cv_sha256_parse_hex(hex, sha));
    CHECK(memcmp(sha, expected, 32) == 0);
    char back[CV_SHA256_HEX_SIZE];
    cv_sha256_hex(sha, back);
    CHECK(strcmp(back, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad") == 0);

    uint8_t untouched[32];
    memset(untouched, 0x5a, 32);
    memcpy(sha, untouched, 32);
    CHECK(!cv_sha256_parse_hex("", sha));
    CHECK(!cv_sha256_parse_hex("ba7816bf", sha)); /* short */
    CHECK(!cv_sha256_parse_hex("ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad0", sha));
    CHECK(!cv_sha256_parse_hex("ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ag", sha));
    CHECK(!cv_sha256_parse_hex("ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015a", sha));
    CHECK(!cv_sha256_parse_hex(" a7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad", sha));
    CHECK(memcmp(sha, untouched, 32) == 0);
}

int main(void) {
    one_shot_vectors();
    million_a_incrementally();
    hex_round_trip();
    return check_report("sha256");
}
