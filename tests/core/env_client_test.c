/* The client library's environment as programs read it (apps/common/env_client.h)
 * and the settings the library takes instead (proxy.h's cv_proxy_configure,
 * transfer.h's cv_transfer_set_path): each variable lands in its field, a bad
 * one is refused naming the variable and sets nothing, and the proxy's options
 * are checked field by field. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "corvid/corvid.h"
#include "env_client.h"

static const char *const variables[] = { "CORVID_TRANSFER_PATH",         "CORVID_NODE_TIMEOUT_MS",
                                         "CORVID_NODE_PEER_DEADLINE_MS", "CORVID_NODE_KEEPALIVE_MS",
                                         "CORVID_NODE_TOKEN_FILE",       "CORVID_NODE_TLS_CA",
                                         "CORVID_NODE_TLS_CERT",         "CORVID_NODE_TLS_KEY" };

static void clear_environment(void) {
    for (size_t i = 0; i < sizeof variables / sizeof variables[0]; i++)
        unsetenv(variables[i]);
}

static void write_file(const char *path, const char *text) {
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

static void test_read(const char *token_file) {
    clear_environment();
    static cv_env_client e;
    CHECK_OK(cv_env_client_read(CV_ENV_CLIENT_ALL, &e));
    CHECK_EQ_INT(e.transfer_path, CV_TRANSFER_AUTO);
    CHECK(e.proxy.timeout_ms == 0 && e.proxy.bearer_token == NULL && e.proxy.tls_ca_file == NULL);
    setenv("CORVID_TRANSFER_PATH", "host-import", 1);
    setenv("CORVID_NODE_TIMEOUT_MS", "2500", 1);
    setenv("CORVID_NODE_PEER_DEADLINE_MS", "700", 1);
    setenv("CORVID_NODE_KEEPALIVE_MS", "1500", 1);
    setenv("CORVID_NODE_TOKEN_FILE", token_file, 1);
    setenv("CORVID_NODE_TLS_CA", "ca.pem", 1);
    CHECK_OK(cv_env_client_read(CV_ENV_CLIENT_ALL, &e));
    CHECK_EQ_INT(e.transfer_path, CV_TRANSFER_HOST_IMPORT);
    CHECK_EQ_INT(e.proxy.timeout_ms, 2500);
    CHECK_EQ_INT(e.proxy.peer_deadline_ms, 700);
    CHECK_EQ_INT(e.proxy.keepalive_ms, 1500);
    CHECK(e.proxy.bearer_token && strcmp(e.proxy.bearer_token, "s3cret") == 0);
    CHECK(e.proxy.tls_ca_file && strcmp(e.proxy.tls_ca_file, "ca.pem") == 0);
    /* A server reads only the transfer path: its CORVID_NODE_TOKEN_FILE is its own token. */
    CHECK_OK(cv_env_client_read(CV_ENV_CLIENT_TRANSFER, &e));
    CHECK_EQ_INT(e.transfer_path, CV_TRANSFER_HOST_IMPORT);
    CHECK(e.proxy.timeout_ms == 0 && e.proxy.bearer_token == NULL);
    clear_environment();
}

static void expect_refused(const char *name, const char *value, const char *message) {
    static cv_env_client e;
    setenv(name, value, 1);
    cv_result r = cv_env_client_read(CV_ENV_CLIENT_ALL, &e);
    CHECK(r != CV_OK);
    if (!strstr(cv_last_error(), message))
        fprintf(stderr, "expected '%s' in: %s\n", message, cv_last_error());
    CHECK(strstr(cv_last_error(), message) != NULL);
    unsetenv(name);
}

static void test_refused(const char *empty_file) {
    clear_environment();
    expect_refused("CORVID_TRANSFER_PATH", "fastest", "CORVID_TRANSFER_PATH: transfer path 'fastest' is not one of");
    expect_refused("CORVID_NODE_TIMEOUT_MS", "abc",
                   "CORVID_NODE_TIMEOUT_MS: 'abc' is not a whole number in 1..86400000 (milliseconds)");
    expect_refused("CORVID_NODE_KEEPALIVE_MS", "50",
                   "CORVID_NODE_KEEPALIVE_MS: '50' is not a whole number in 100..3600000 (milliseconds)");
    expect_refused("CORVID_NODE_TOKEN_FILE", empty_file, "CORVID_NODE_TOKEN_FILE: ");
    expect_refused("CORVID_NODE_TLS_CERT", "cert.pem", "CORVID_NODE_TLS_CERT/KEY (a client certificate) need");
    setenv("CORVID_NODE_TLS_CA", "ca.pem", 1);
    expect_refused("CORVID_NODE_TLS_KEY", "key.pem", "CORVID_NODE_TLS_KEY is set without CORVID_NODE_TLS_CERT");
    clear_environment();
}

/* configure sets the library's settings; a bad variable sets none of them. */
static void test_configure(void) {
    clear_environment();
    setenv("CORVID_TRANSFER_PATH", "staged", 1);
    CHECK_OK(cv_env_client_configure(CV_ENV_CLIENT_ALL));
    cv_transfer_path mode = CV_TRANSFER_AUTO;
    CHECK_OK(cv_transfer_mode(&mode));
    CHECK_EQ_INT(mode, CV_TRANSFER_STAGED);
    setenv("CORVID_TRANSFER_PATH", "shared", 1);
    setenv("CORVID_NODE_TIMEOUT_MS", "0", 1);
    CHECK_RESULT(cv_env_client_configure(CV_ENV_CLIENT_ALL), CV_ERROR_INVALID_ARGUMENT);
    CHECK_OK(cv_transfer_mode(&mode));
    CHECK_EQ_INT(mode, CV_TRANSFER_STAGED);
    cv_transfer_clear_path();
    CHECK_OK(cv_transfer_mode(&mode));
    CHECK_EQ_INT(mode, CV_TRANSFER_AUTO);
    clear_environment();
}

static void test_proxy_options(void) {
    CHECK_OK(cv_proxy_configure(NULL));
    CHECK_OK(cv_proxy_configure(&(cv_proxy_options){ .timeout_ms = 1, .keepalive_ms = 100, .bearer_token = "t" }));
    CHECK_RESULT(cv_proxy_configure(&(cv_proxy_options){ .keepalive_ms = 99 }), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "keepalive_ms 99 is not in 100..3600000") != NULL);
    CHECK_RESULT(cv_proxy_configure(&(cv_proxy_options){ .timeout_ms = 86400001 }), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "timeout_ms") != NULL);
    CHECK_RESULT(cv_proxy_configure(&(cv_proxy_options){ .tls_cert_file = "c.pem", .tls_key_file = "k.pem" }),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "needs tls_ca_file") != NULL);
    CHECK_RESULT(cv_proxy_configure(&(cv_proxy_options){ .tls_ca_file = "ca.pem", .tls_key_file = "k.pem" }),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "tls_key_file is set without tls_cert_file") != NULL);
    char long_token[2048];
    memset(long_token, 'x', sizeof long_token - 1);
    long_token[sizeof long_token - 1] = '\0';
    CHECK_RESULT(cv_proxy_configure(&(cv_proxy_options){ .bearer_token = long_token }), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "bearer_token of 2047 characters is too long") != NULL);
    CHECK_OK(cv_proxy_configure(NULL));
}

int main(void) {
    char dir[] = "/tmp/corvid-env-XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char token_file[64], empty_file[64];
    snprintf(token_file, sizeof token_file, "%s/token", dir);
    snprintf(empty_file, sizeof empty_file, "%s/empty", dir);
    write_file(token_file, "s3cret\n");
    write_file(empty_file, "\n");
    test_read(token_file);
    test_refused(empty_file);
    test_configure();
    test_proxy_options();
    unlink(token_file);
    unlink(empty_file);
    rmdir(dir);
    CHECK_NOTHING_LIVE();
    return check_report("env_client");
}
