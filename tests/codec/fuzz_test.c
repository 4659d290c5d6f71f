/* Mutated encodings never crash the decoder (CI runs this under ASan and
 * UBSan): each of 2000 mutations of valid encodings (bit flips, byte
 * overwrites, truncations, inserted and deleted bytes, spliced copies) either
 * decodes to a list that ended cleanly and round-trips again, or fails with a
 * decoder or recording error and leaves the target list untouched. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "corvid/command_codec.h"
#include "random_list.h"

#define MUTATIONS 2000
#define BASE_LISTS 4

static bool expected_failure(cv_result r) {
    switch (r) {
    case CV_ERROR_MALFORMED:
    case CV_ERROR_LIMIT_EXCEEDED:
    case CV_ERROR_INVALID_HANDLE:
    case CV_ERROR_WRONG_HANDLE_TYPE:
    case CV_ERROR_QUEUE_MISMATCH:
    case CV_ERROR_BAD_STATE:
    case CV_ERROR_INVALID_ARGUMENT: return true;
    default: return false;
    }
}

/* Writes a mutation of `in` into `out` (room for size + 64) and returns its size. */
static size_t mutate(test_rng *r, const uint8_t *in, size_t size, uint8_t *out) {
    memcpy(out, in, size);
    size_t pos = test_rng_below(r, (uint32_t)size);
    switch (test_rng_below(r, 6)) {
    case 0: /* flip 1 to 4 bits */
        for (uint32_t n = 1 + test_rng_below(r, 4); n > 0; n--)
            out[test_rng_below(r, (uint32_t)size)] ^= (uint8_t)(1u << test_rng_below(r, 8));
        return size;
    case 1: /* overwrite a byte with a length-ish or key-ish value */
        out[pos] = (uint8_t)test_rng_next(r);
        return size;
    case 2: /* truncate */ return pos;
    case 3: { /* insert up to 8 random bytes */
        uint32_t n = 1 + test_rng_below(r, 8);
        memmove(out + pos + n, out + pos, size - pos);
        for (uint32_t i = 0; i < n; i++)
            out[pos + i] = (uint8_t)test_rng_next(r);
        return size + n;
    }
    case 4: { /* delete up to 8 bytes */
        size_t n = 1 + test_rng_below(r, 8);
        if (n > size - pos)
            n = size - pos;
        memmove(out + pos, out + pos + n, size - pos - n);
        return size - n;
    }
    default: { /* copy up to 64 bytes from elsewhere over this spot */
        size_t from = test_rng_below(r, (uint32_t)size);
        size_t n = 1 + test_rng_below(r, 64);
        if (n > size - from)
            n = size - from;
        if (n > size - pos)
            n = size - pos;
        memmove(out + pos, in + from, n);
        return size;
    }
    }
}

int main(void) {
    uint8_t *base[BASE_LISTS];
    size_t base_size[BASE_LISTS];
    for (int i = 0; i < BASE_LISTS; i++) {
        cv_command_list list;
        cv_command_list_init(&list);
        CHECK_OK(random_list_record(&list, 900 + (uint64_t)i, 6));
        CHECK_OK(cv_command_list_encode(&list, &base[i], &base_size[i]));
        cv_command_list_finish(&list);
    }

    /* The target holds a decoded list throughout; failures must not touch it. */
    cv_command_list reference, target;
    cv_command_list_init(&reference);
    cv_command_list_init(&target);
    CHECK_OK(cv_command_list_decode(base[0], base_size[0], &reference));
    CHECK_OK(cv_command_list_decode(base[0], base_size[0], &target));

    test_rng r = { 77 };
    int decoded = 0, rejected = 0;
    for (int i = 0; i < MUTATIONS; i++) {
        int which = (int)test_rng_below(&r, BASE_LISTS);
        uint8_t *input = malloc(base_size[which] + 64);
        size_t size = mutate(&r, base[which], base_size[which], input);
        /* An exact-size copy, so ASan sees any read past the input's end. */
        uint8_t *exact = malloc(size ? size : 1);
        memcpy(exact, input, size);
        uint32_t version = target.version;
        cv_result res = cv_command_list_decode(exact, size, &target);
        if (res == CV_OK) {
            decoded++;
            CHECK(target.ended_ok);
            uint8_t *again;
            size_t again_size;
            CHECK_OK(cv_command_list_encode(&target, &again, &again_size));
            cv_command_list check;
            cv_command_list_init(&check);
            CHECK_OK(cv_command_list_decode(again, again_size, &check));
            CHECK(lists_equal(&target, &check, "re-decoded mutation"));
            cv_command_list_finish(&check);
            free(again);
            /* Back to the reference for the next failure checks. */
            CHECK_OK(cv_command_list_decode(base[0], base_size[0], &target));
        } else {
            rejected++;
            if (!expected_failure(res))
                fprintf(stderr, "mutation %d: unexpected %s: %s\n", i, cv_result_name(res), cv_last_error());
            CHECK(expected_failure(res));
            CHECK(cv_last_error()[0] != '\0');
            CHECK_EQ_INT(target.version, version);
            CHECK(lists_equal(&reference, &target, "target after a rejected mutation"));
        }
        free(exact);
        free(input);
    }
    printf("codec_fuzz: %d mutations decoded, %d rejected\n", decoded, rejected);
    CHECK_EQ_INT(decoded + rejected, MUTATIONS);
    /* Both outcomes occur, or the mutations are not exercising the decoder. */
    CHECK(decoded > 0);
    CHECK(rejected > MUTATIONS / 4);

    for (int i = 0; i < BASE_LISTS; i++)
        free(base[i]);
    cv_command_list_finish(&reference);
    cv_command_list_finish(&target);
    return check_report("codec_fuzz");
}
