/* corvid_web over loopback: assets, the API handler, refusals (401, 404, 405, 413),
 * the desc checks, and WebSocket text and frames (a newer frame replaces an unsent
 * one), connections closed at stop. */
#include "check.h"
#include "web_client.h"

#include <corvid/web_server.h>

#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const uint8_t PAGE[] = "<!doctype html><p>hello</p>";
static const cv_web_asset ASSETS[] = { { "/", "text/html", PAGE, sizeof PAGE - 1 } };

typedef struct fixture {
    pthread_mutex_t lock;
    int api_calls, opened, closed;
    char last_text[256];
} fixture;

static void api(void *user, const cv_http_request *req, cv_http_response *resp) {
    fixture *f = user;
    pthread_mutex_lock(&f->lock);
    f->api_calls++;
    pthread_mutex_unlock(&f->lock);
    if (strcmp(req->path, "/api/v1/echo") == 0) {
        char json[512];
        snprintf(json, sizeof json, "{\"method\":\"%s\",\"query\":\"%s\",\"type\":\"%s\",\"body\":\"%.*s\"}",
                 req->method, req->query, req->content_type, (int)req->body_size, (const char *)req->body);
        cv_http_respond_json(resp, 200, json);
    } else if (strcmp(req->path, "/api/v1/fail") == 0) {
        cv_http_respond_error(resp, 422, "field \"x\": out of range");
    }
}

static void ws_open(void *user, cv_web_conn *c) {
    fixture *f = user;
    (void)c;
    pthread_mutex_lock(&f->lock);
    f->opened++;
    pthread_mutex_unlock(&f->lock);
}

/* On the service thread: two frames before it can write either, so the first is replaced;
 * eight in-order frames, none replaced. */
static void ws_text(void *user, cv_web_conn *c, const char *text, size_t size) {
    fixture *f = user;
    pthread_mutex_lock(&f->lock);
    snprintf(f->last_text, sizeof f->last_text, "%.*s", (int)size, text);
    pthread_mutex_unlock(&f->lock);
    if (strcmp(text, "frames") == 0) {
        CHECK_OK(cv_web_send_binary(c, "old", 3));
        CHECK_OK(cv_web_send_binary(c, "newest", 6));
    } else if (strcmp(text, "stream") == 0) { /* in-order frames: none gives way, the ninth is refused */
        char frame[8];
        for (int i = 0; i < 8; i++) {
            snprintf(frame, sizeof frame, "f%d", i);
            CHECK_OK(cv_web_send_binary_in_order(c, frame, 2));
        }
        CHECK_RESULT(cv_web_send_binary_in_order(c, "f8", 2), CV_ERROR_LIMIT_EXCEEDED);
    } else {
        CHECK_OK(cv_web_send_text(c, "{\"echo\":true}"));
    }
}

static void ws_close(void *user, cv_web_conn *c) {
    fixture *f = user;
    (void)c;
    pthread_mutex_lock(&f->lock);
    f->closed++;
    pthread_mutex_unlock(&f->lock);
}

static cv_web_desc desc_for(fixture *f, const char *token) {
    return (cv_web_desc){ .token = token,
                          .max_body_bytes = 64,
                          .assets = ASSETS,
                          .asset_count = 1,
                          .api = api,
                          .api_user = f,
                          .ws_open = ws_open,
                          .ws_text = ws_text,
                          .ws_close = ws_close,
                          .ws_user = f,
                          .ws_max_message_bytes = 1024 };
}

static int status_of(uint16_t port, const char *method, const char *path, const char *headers, const char *body) {
    web_reply r;
    if (web_request(port, method, path, headers, body, body ? strlen(body) : 0, &r) != 0)
        return -1;
    int st = r.status;
    web_reply_free(&r);
    return st;
}

static void test_http(fixture *f, uint16_t port) {
    web_reply r;
    CHECK(web_request(port, "GET", "/", NULL, NULL, 0, &r) == 0);
    CHECK_EQ_INT(r.status, 200);
    CHECK(r.body_size == sizeof PAGE - 1 && memcmp(r.body, PAGE, r.body_size) == 0);
    CHECK(strcasestr(r.headers, "content-type: text/html") != NULL);
    web_reply_free(&r);
    CHECK(web_request(port, "POST", "/api/v1/echo?a=1&b=2", "Content-Type: text/plain\r\n", "hi", 2, &r) == 0);
    CHECK_EQ_INT(r.status, 200);
    CHECK(r.body && strcmp((char *)r.body,
                           "{\"method\":\"POST\",\"query\":\"a=1&b=2\",\"type\":\"text/plain\","
                           "\"body\":\"hi\"}") == 0);
    web_reply_free(&r);
    CHECK(web_request(port, "GET", "/api/v1/fail", NULL, NULL, 0, &r) == 0);
    CHECK_EQ_INT(r.status, 422);
    CHECK(r.body && strcmp((char *)r.body, "{\"error\":\"field \\\"x\\\": out of range\"}") == 0);
    web_reply_free(&r);
    CHECK(web_request(port, "GET", "/nothing", NULL, NULL, 0, &r) == 0);
    CHECK_EQ_INT(r.status, 404);
    CHECK(r.body && strstr((char *)r.body, "\"error\"") != NULL);
    web_reply_free(&r);
    CHECK_EQ_INT(status_of(port, "GET", "/api/v1/unknown", NULL, NULL), 404);
    CHECK_EQ_INT(status_of(port, "POST", "/", NULL, "x"), 405);
    CHECK_EQ_INT(status_of(port, "HEAD", "/", NULL, NULL), 200);
    pthread_mutex_lock(&f->lock);
    int calls = f->api_calls;
    pthread_mutex_unlock(&f->lock);
    char big[65 + 1];
    memset(big, 'x', 65);
    big[65] = 0;
    CHECK_EQ_INT(status_of(port, "POST", "/api/v1/echo", NULL, big), 413);
    CHECK_EQ_INT(status_of(port, "PATCH", "/api/v1/echo", "Transfer-Encoding: chunked\r\n", NULL), 411);
    pthread_mutex_lock(&f->lock);
    CHECK_EQ_INT(f->api_calls, calls); /* refused before the handler */
    pthread_mutex_unlock(&f->lock);
}

static void test_ws(fixture *f, cv_web_server *s, uint16_t port) {
    CHECK_EQ_INT(web_ws_connect(port, "/elsewhere"), -404);
    int fd = web_ws_connect(port, "/ws");
    CHECK(fd >= 0);
    if (fd < 0)
        return;
    uint8_t buf[2048];
    int op = 0;
    CHECK(web_ws_send_text(fd, "{\"hello\":1}") == 0);
    CHECK_EQ_INT(web_ws_read(fd, &op, buf, sizeof buf), 13);
    CHECK_EQ_INT(op, 1);
    CHECK(memcmp(buf, "{\"echo\":true}", 13) == 0);
    CHECK(web_ws_send_text(fd, "frames") == 0);
    CHECK_EQ_INT(web_ws_read(fd, &op, buf, sizeof buf), 6);
    CHECK_EQ_INT(op, 2);
    CHECK(memcmp(buf, "newest", 6) == 0);
    cv_web_stats st;
    cv_web_server_get_stats(s, &st);
    CHECK_EQ_INT(st.binary_replaced, 1);
    CHECK_EQ_INT(st.binary_sent, 1);
    CHECK_EQ_INT(st.ws_open_now, 1);
    CHECK(web_ws_send_text(fd, "stream") == 0);
    for (int i = 0; i < 8; i++) {
        char want[8];
        snprintf(want, sizeof want, "f%d", i);
        CHECK_EQ_INT(web_ws_read(fd, &op, buf, sizeof buf), 2);
        CHECK(op == 2 && memcmp(buf, want, 2) == 0);
    }
    cv_web_server_get_stats(s, &st);
    CHECK_EQ_INT(st.binary_replaced, 1);
    CHECK_EQ_INT(st.binary_dropped, 1);
    CHECK_EQ_INT(st.binary_sent, 9);
    pthread_mutex_lock(&f->lock);
    CHECK_EQ_INT(f->opened, 1);
    CHECK(strcmp(f->last_text, "stream") == 0);
    pthread_mutex_unlock(&f->lock);
    /* A message over ws_max_message_bytes closes the connection. */
    char *huge = malloc(2000);
    memset(huge, 'a', 1999);
    huge[1999] = 0;
    CHECK(web_ws_send_text(fd, huge) == 0);
    long n = web_ws_read(fd, &op, buf, sizeof buf);
    CHECK(n < 0 || op == 8);
    free(huge);
    close(fd);
}

static void test_token(fixture *f) {
    cv_web_desc d = desc_for(f, "s3cret");
    cv_web_server *s = NULL;
    CHECK_OK(cv_web_server_start(&d, &s));
    uint16_t port = cv_web_server_port(s);
    CHECK_EQ_INT(status_of(port, "GET", "/", NULL, NULL), 401);
    CHECK_EQ_INT(status_of(port, "GET", "/?token=s3cret", NULL, NULL), 200);
    CHECK_EQ_INT(status_of(port, "GET", "/?token=wrong", NULL, NULL), 401);
    CHECK_EQ_INT(status_of(port, "GET", "/api/v1/echo", NULL, NULL), 401);
    CHECK_EQ_INT(status_of(port, "GET", "/api/v1/echo?token=s3cret", NULL, NULL), 401); /* API: header only */
    CHECK_EQ_INT(status_of(port, "GET", "/api/v1/echo", "Authorization: Bearer s3cret\r\n", NULL), 200);
    CHECK_EQ_INT(status_of(port, "GET", "/api/v1/echo", "Authorization: Bearer s3cre\r\n", NULL), 401);
    CHECK_EQ_INT(status_of(port, "GET", "/nothing", NULL, NULL), 401); /* no path is revealed */
    CHECK_EQ_INT(web_ws_connect(port, "/ws"), -401);
    int fd = web_ws_connect(port, "/ws?token=s3cret");
    CHECK(fd >= 0);
    cv_web_server_stop(s); /* with the connection open: its close callback runs */
    if (fd >= 0)
        close(fd);
}

static void test_desc(fixture *f) {
    cv_web_server *s = NULL;
    cv_web_desc d = desc_for(f, NULL);
    d.host = "0.0.0.0";
    CHECK_RESULT(cv_web_server_start(&d, &s), CV_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(cv_last_error(), "token") != NULL);
    d = desc_for(f, NULL);
    d.tls_cert = "/nonexistent.pem";
    CHECK_RESULT(cv_web_server_start(&d, &s), CV_ERROR_INVALID_ARGUMENT);
    d = desc_for(f, NULL);
    d.tls_cert = "/nonexistent.pem";
    d.tls_key = "/nonexistent.key";
    CHECK(cv_web_server_start(&d, &s) != CV_OK);
    CHECK(s == NULL);
}

int main(void) {
    fixture f = { .lock = PTHREAD_MUTEX_INITIALIZER };
    cv_web_desc d = desc_for(&f, NULL);
    cv_web_server *s = NULL;
    CHECK_OK(cv_web_server_start(&d, &s));
    if (s) {
        uint16_t port = cv_web_server_port(s);
        CHECK(port != 0);
        test_http(&f, port);
        test_ws(&f, s, port);
        cv_web_server_stop(s);
    }
    test_token(&f);
    CHECK_EQ_INT(f.opened, 2);
    CHECK_EQ_INT(f.closed, 2);
    test_desc(&f);
    CHECK_NOTHING_LIVE();
    return check_report("test_web_server");
}
