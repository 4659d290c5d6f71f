/* What people type and name, read the same way everywhere: whole numbers
 * (corvid/parse.h: no sign, no blanks), files (corvid/file_util.h: a FIFO or a
 * directory is refused at once, never blocked on), error messages that keep
 * their reason when a path is very long (result.h), and a device call that
 * names what the caller did (a write, not "buffer read"). */
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "corvid/corvid.h"
#include "corvid/file_util.h"
#include "corvid/parse.h"

static void test_parse_uint(void) {
    uint64_t v = 7;
    CHECK(cv_parse_uint("12", 1, 64, &v) && v == 12);
    CHECK(cv_parse_uint("0", 0, 0, &v) && v == 0);
    CHECK(cv_parse_uint("18446744073709551615", 0, UINT64_MAX, &v) && v == UINT64_MAX);
    const char *bad[] = { "+2", " 2", "2 ", "-1", "0x10", "2abc", "", "abc", "18446744073709551616", "65" };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        v = 7;
        CHECK(!cv_parse_uint(bad[i], 0, 64, &v));
        CHECK_EQ_INT(v, 7); /* unchanged */
    }
    CHECK(!cv_parse_uint(NULL, 0, 64, &v));
    CHECK_RESULT(cv_parse_uint_named("CORVID_NODE_TIMEOUT_MS", "abc", 1, 86400000, &v), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strcmp(cv_last_error(), "CORVID_NODE_TIMEOUT_MS: 'abc' is not a whole number in 1..86400000") == 0);
}

static void test_regular_files(void) {
    char dir[] = "/tmp/corvid-inputs-XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char fifo[64], plain[64];
    snprintf(fifo, sizeof fifo, "%s/fifo", dir);
    snprintf(plain, sizeof plain, "%s/plain", dir);
    CHECK(mkfifo(fifo, 0600) == 0);
    int fd = -1;
    /* Reading or writing a FIFO nobody holds open would block; refused at once instead. */
    CHECK_RESULT(cv_file_open_regular(fifo, O_RDONLY, 0, &fd), CV_ERROR_IO);
    CHECK(strstr(cv_last_error(), "/fifo: is not a regular file (a FIFO)") != NULL);
    FILE *f = NULL;
    CHECK_RESULT(cv_file_fopen_regular(fifo, "w", &f), CV_ERROR_IO);
    CHECK(strstr(cv_last_error(), "/fifo: is not a regular file (a FIFO)") != NULL);
    CHECK_RESULT(cv_file_fopen_regular(dir, "r", &f), CV_ERROR_IO);
    CHECK(strstr(cv_last_error(), ": is not a regular file (a directory)") != NULL);
    CHECK_RESULT(cv_file_open_regular("/dev/null", O_RDONLY, 0, &fd), CV_ERROR_IO);
    CHECK(strcmp(cv_last_error(), "/dev/null: is not a regular file (a character device)") == 0);
    CHECK_OK(cv_file_fopen_regular(plain, "w", &f));
    CHECK(fputs("42\n", f) >= 0 && fclose(f) == 0);
    CHECK_OK(cv_file_open_regular(plain, O_RDONLY, 0, &fd));
    char text[8] = "";
    CHECK_EQ_INT(read(fd, text, sizeof text), 3); /* blocking again, and the bytes written */
    CHECK(fcntl(fd, F_GETFL) >= 0 && !(fcntl(fd, F_GETFL) & O_NONBLOCK));
    close(fd);
    CHECK(strncmp(text, "42\n", 3) == 0);
    unlink(plain);
    unlink(fifo);
    rmdir(dir);
}

/* A message longer than CV_ERROR_MESSAGE_MAX keeps its end: the reason after a long path. */
static void test_long_message(void) {
    size_t n = CV_ERROR_MESSAGE_MAX + 100;
    char *path = malloc(n + 1);
    CHECK(path != NULL);
    if (!path)
        return;
    memset(path, 'p', n);
    path[0] = '/';
    path[n] = '\0';
    CHECK_RESULT(cv_error(CV_ERROR_IO, "%s: File name too long", path), CV_ERROR_IO);
    const char *e = cv_last_error();
    CHECK_EQ_INT(strlen(e), CV_ERROR_MESSAGE_MAX - 1);
    CHECK(e[0] == '/');
    CHECK(strstr(e, "p [...] p") != NULL);
    CHECK(strcmp(e + strlen(e) - strlen(": File name too long"), ": File name too long") == 0);
    /* Wrapped once more (as callers add where it happened): the end is still there. */
    cv_error(CV_ERROR_IO, "--out: %s", cv_last_error());
    e = cv_last_error();
    CHECK(strncmp(e, "--out: /", 8) == 0);
    CHECK(strcmp(e + strlen(e) - strlen(": File name too long"), ": File name too long") == 0);
    free(path);
}

/* cv_device_write_buffer with no data is a write, not a "buffer read". */
static void test_null_write_named(void) {
    cv_context *ctx;
    cv_device *dev;
    CHECK_OK(cv_context_create(NULL, &ctx));
    CHECK_OK(cv_device_create(ctx, cv_mock_backend(), &(cv_device_desc){ .label = "m" }, &dev));
    cv_buffer b;
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = 16, .label = "b" }, &b));
    CHECK_RESULT(cv_device_write_buffer(dev, b, 0, 4, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strcmp(cv_last_error(), "buffer write: NULL argument") == 0);
    CHECK_RESULT(cv_device_read_buffer(dev, b, 0, 4, NULL), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strcmp(cv_last_error(), "buffer read: NULL argument") == 0);
    CHECK_OK(cv_buffer_destroy(ctx, b));
    cv_context_destroy(ctx);
}

int main(void) {
    test_parse_uint();
    test_regular_files();
    test_long_message();
    test_null_write_named();
    CHECK_NOTHING_LIVE();
    return check_report("inputs");
}
