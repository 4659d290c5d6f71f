/* corvid-node's Prometheus metrics, scraped over HTTP as Prometheus would.
 *
 * A node with 2 mock devices runs in this process with its /metrics endpoint on
 * a free loopback port. The test does a known amount of work through the proxy
 * backend, one session per node device: creates, inline and content-addressed
 * writes (the second session writes the blob the first uploaded), N submissions
 * of a list with a marked pass, a destroy, reads. Then it fetches /metrics with
 * a small socket client and checks every counter against what it did and what
 * the proxy's own statistics say; checks the text with `promtool check metrics`
 * when promtool is installed; ends the sessions and checks the gauges fall back
 * to 0; and checks 404/405, the content type, and the snprintf-style
 * cv_node_metrics_text. Hostile scrapers: 64 idle connections do not keep a
 * scrape out, a client trickling one byte at a time is cut off at the deadline,
 * and a server with a token answers 401 without it. */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include "check.h"
#include "corvid/command_list.h"
#include "corvid/proxy.h"
#include "metrics_http.h"
#include "metrics_text.h"
#include "scratch_node.h"

#define SUBMISSIONS 5
#define BIG (256u << 10) /* CV_NODE_BLOB_MIN_BYTES: written through the content store */

static scratch_node node;
static cv_metrics_server *metrics;

/* ---- a tiny HTTP/1.0 client -------------------------------------------------- */

typedef struct http_answer {
    int status;
    char content_type[128];
    char *body; /* malloc'd, NUL-terminated */
} http_answer;

/* A socket connected to 127.0.0.1:port (-1 if not). */
static int connect_to(int port) {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in addr = { .sin_family = AF_INET, .sin_port = htons((uint16_t)port) };
    inet_pton(AF_INET, "127.0.0.1", &addr.sin_addr);
    if (fd < 0 || connect(fd, (struct sockaddr *)&addr, sizeof(addr)) != 0) {
        fprintf(stderr, "metrics: cannot connect to 127.0.0.1:%d\n", port);
        if (fd >= 0)
            close(fd);
        return -1;
    }
    return fd;
}

/* How long a request may wait for its answer (0 = forever); the idle-connection case sets it. */
static int answer_timeout_s;

/* `header`: one more header line ("Name: value"), or NULL. */
static bool http_request_to(cv_metrics_server *server, const char *method, const char *path, const char *header,
                            http_answer *out) {
    memset(out, 0, sizeof(*out));
    int fd = connect_to(cv_metrics_server_port(server));
    if (fd < 0)
        return false;
    struct timeval tv = { .tv_sec = answer_timeout_s };
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
    char request[512];
    int n = snprintf(request, sizeof(request), "%s %s HTTP/1.0\r\nHost: 127.0.0.1\r\n%s%s\r\n", method, path,
                     header ? header : "", header ? "\r\n" : "");
    if (write(fd, request, (size_t)n) != n) {
        close(fd);
        return false;
    }
    size_t cap = 1 << 16, len = 0;
    char *all = malloc(cap);
    for (ssize_t got; all && (got = read(fd, all + len, cap - len - 1)) > 0;) {
        len += (size_t)got;
        if (len + 1 == cap)
            all = realloc(all, cap *= 2);
    }
    close(fd);
    if (!all)
        return false;
    all[len] = '\0';
    char *body = strstr(all, "\r\n\r\n");
    if (sscanf(all, "HTTP/1.%*d %d", &out->status) != 1 || !body) {
        free(all);
        return false;
    }
    *body = '\0';
    const char *ct = strstr(all, "\r\nContent-Type: ");
    if (ct)
        sscanf(ct + 16, "%127[^\r\n]", out->content_type);
    out->body = strdup(body + 4);
    free(all);
    return out->body != NULL;
}

static bool http_request(const char *method, const char *path, http_answer *out) {
    return http_request_to(metrics, method, path, NULL, out);
}

/* GET /metrics; the body (malloc'd) or NULL. */
static char *scrape(void) {
    http_answer a;
    if (!http_request("GET", "/metrics", &a))
        return NULL;
    CHECK_EQ_INT(a.status, 200);
    return a.body;
}

/* The value of the sample `series` (name with its labels, as written), or -1 if absent. */
static double sample(const char *text, const char *series) {
    size_t len = strlen(series);
    for (const char *line = text; line && *line; line = strchr(line, '\n') ? strchr(line, '\n') + 1 : NULL)
        if (strncmp(line, series, len) == 0 && line[len] == ' ')
            return strtod(line + len + 1, NULL);
    return -1;
}

#define CHECK_SAMPLE(text, series, expected) \
    do { \
        double got_ = sample(text, series); \
        if (got_ != (double)(expected)) \
            fprintf(stderr, "  %s = %.17g, expected %.17g\n", series, got_, (double)(expected)); \
        CHECK(got_ == (double)(expected)); \
    } while (0)

/* ---- the work ----------------------------------------------------------------- */

static cv_device *proxy_device(cv_context *ctx, const char *adapter) {
    cv_device *dev = NULL;
    cv_device_desc desc = { .endpoint = node.endpoint, .adapter = adapter };
    snprintf(desc.label, sizeof(desc.label), "remote%s", adapter);
    CHECK_OK(cv_device_create(ctx, cv_proxy_backend(), &desc, &dev));
    return dev;
}

static cv_buffer loaded_buffer(cv_context *ctx, cv_device *dev, uint64_t size) {
    cv_buffer b = { 0 };
    CHECK_OK(cv_buffer_create(ctx, &(cv_buffer_desc){ .size = size }, &b));
    CHECK_OK(cv_device_load(dev, cv_any(b)));
    return b;
}

/* Session on mock0: 2 x 4 KiB + a 256 KiB buffer + a 16x16 RGBA8 texture (1 KiB) live,
 * the 256 KiB blob uploaded (a cache miss), SUBMISSIONS submissions of a list with one
 * marked pass ("frame") that copies 4 KiB, read back. */
static void work_on_mock0(cv_context *ctx, cv_device *dev, const uint8_t *big) {
    uint8_t src_bytes[4096], back[4096];
    for (int i = 0; i < 4096; i++)
        src_bytes[i] = (uint8_t)(i * 7 + 1);
    cv_buffer src = loaded_buffer(ctx, dev, 4096), dst = loaded_buffer(ctx, dev, 4096);
    cv_buffer large = loaded_buffer(ctx, dev, BIG);
    cv_texture tex = { 0 };
    CHECK_OK(cv_texture_create(ctx, &(cv_texture_desc){ .width = 16, .height = 16, .format = CV_FORMAT_RGBA8_UNORM },
                               &tex));
    CHECK_OK(cv_device_load(dev, cv_any(tex)));
    CHECK_OK(cv_device_write_buffer(dev, src, 0, sizeof(src_bytes), src_bytes));
    CHECK_OK(cv_device_write_buffer(dev, large, 0, BIG, big));

    cv_cmdlist list;
    cv_command_list *l;
    CHECK_OK(cv_cmdlist_create(ctx, &list));
    CHECK_OK(cv_cmdlist_begin(ctx, list, &l));
    cv_cmd_begin_marker(l, CV_QUEUE_COPY, &(cv_begin_marker_args){ .label = "frame" });
    cv_cmd_copy_buffer(l, CV_QUEUE_COPY, &(cv_copy_buffer_args){ .src = src, .dst = dst, .size = 4096 });
    cv_cmd_end_marker(l, CV_QUEUE_COPY, &(cv_end_marker_args){ 0 });
    CHECK_OK(cv_command_list_end(l));
    /* Each waited for before the next: a device keeps the timings of a list's latest
     * submission only, so back-to-back submissions may report fewer passes. */
    for (int i = 0; i < SUBMISSIONS; i++) {
        uint64_t ticket = 0;
        CHECK_OK(cv_device_submit(dev, list, &ticket));
        CHECK_OK(cv_device_wait(dev, ticket, 10ull * 1000 * 1000 * 1000));
    }
    CHECK_OK(cv_device_read_buffer(dev, dst, 0, sizeof(back), back));
    CHECK(memcmp(back, src_bytes, sizeof(back)) == 0);
}

/* Session on mock1: the same 256 KiB written again (a cache hit, no upload), that
 * buffer destroyed, a 512-byte buffer left live. */
static void work_on_mock1(cv_context *ctx, cv_device *dev, const uint8_t *big) {
    cv_buffer again = loaded_buffer(ctx, dev, BIG);
    CHECK_OK(cv_device_write_buffer(dev, again, 0, BIG, big));
    CHECK_OK(cv_buffer_destroy(ctx, again));
    cv_buffer small = loaded_buffer(ctx, dev, 512);
    uint8_t bytes[512] = { 1, 2, 3 }, back[512];
    CHECK_OK(cv_device_write_buffer(dev, small, 0, sizeof(bytes), bytes));
    CHECK_OK(cv_device_read_buffer(dev, small, 0, sizeof(back), back)); /* a round trip: all of it done */
    CHECK(memcmp(back, bytes, sizeof(back)) == 0);
}

static void check_promtool(const char *text) {
    if (system("command -v promtool >/dev/null 2>&1") != 0) {
        printf("metrics: promtool not installed (Debian package prometheus): format check skipped\n");
        return;
    }
    char path[] = "/tmp/corvid-metrics-XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    if (fd < 0)
        return;
    size_t len = strlen(text);
    CHECK(write(fd, text, len) == (ssize_t)len);
    close(fd);
    char cmd[128];
    snprintf(cmd, sizeof(cmd), "promtool check metrics < %s", path);
    int status = system(cmd);
    if (status != 0)
        fprintf(stderr, "metrics: promtool check metrics failed on:\n%s\n", text);
    CHECK_EQ_INT(status, 0);
    printf("metrics: promtool check metrics: %s\n", status == 0 ? "ok" : "FAILED");
    unlink(path);
}

/* ---- hostile scrapers ---------------------------------------------------------- */

#define IDLE_CONNECTIONS 64

/* Connections that send nothing do not keep a scrape out (the endpoint took 32 and waited 10 s on each):
 * the scrape is answered while they are all still open (before the 5 s deadline that ends them). */
static void idle_connections(void) {
    int fds[IDLE_CONNECTIONS];
    for (int i = 0; i < IDLE_CONNECTIONS; i++)
        fds[i] = connect_to(cv_metrics_server_port(metrics));
    answer_timeout_s = 4;
    char *text = scrape();
    answer_timeout_s = 0;
    CHECK(text && sample(text, "corvid_node_sessions_total") >= 0);
    free(text);
    for (int i = 0; i < IDLE_CONNECTIONS; i++)
        if (fds[i] >= 0)
            close(fds[i]);
}

/* A client that sends a byte every 100 ms, never ending its headers, is cut off at the server's deadline (1 s
 * here) though no read ever waited long: true if the server closed the connection within 40 bytes. */
static bool slowloris_cut(cv_metrics_server *server) {
    int fd = connect_to(cv_metrics_server_port(server));
    if (fd < 0)
        return false;
    static const char trickle[] =
        "GET /metrics HTTP/1.1\r\nX-Slow: aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa";
    bool cut = false;
    for (int i = 0; i < 40 && !cut; i++) {
        if (send(fd, &trickle[i], 1, MSG_NOSIGNAL) != 1) {
            cut = true;
            break;
        }
        struct pollfd p = { .fd = fd, .events = POLLIN };
        char byte;
        if (poll(&p, 1, 100) > 0 && recv(fd, &byte, 1, 0) <= 0)
            cut = true;
    }
    close(fd);
    return cut;
}

/* A server with a token and a 1 s deadline: 401 without the token or with a wrong one, 200 with it; a
 * slowloris is cut off. */
static void guarded_server(void) {
    cv_metrics_server *guarded = NULL;
    CHECK_RESULT(cv_metrics_server_start(node.node, &(cv_metrics_server_config){ .token = "" }, &guarded),
                 CV_ERROR_INVALID_ARGUMENT);
    CHECK_OK(cv_metrics_server_start(node.node, &(cv_metrics_server_config){ .token = "s3cret", .deadline_ms = 1000 },
                                     &guarded));
    http_answer a;
    CHECK(http_request_to(guarded, "GET", "/metrics", NULL, &a));
    CHECK_EQ_INT(a.status, 401);
    CHECK(strstr(a.body, "Authorization: Bearer") != NULL);
    free(a.body);
    CHECK(http_request_to(guarded, "GET", "/metrics", "Authorization: Bearer wrong", &a));
    CHECK_EQ_INT(a.status, 401);
    CHECK(strstr(a.body, "corvid_node_") == NULL);
    free(a.body);
    CHECK(http_request_to(guarded, "GET", "/metrics", "Authorization: Bearer s3cret", &a));
    CHECK_EQ_INT(a.status, 200);
    CHECK(strstr(a.body, "corvid_node_sessions_total") != NULL);
    free(a.body);
    CHECK(slowloris_cut(guarded));
    cv_metrics_server_stop(guarded);
}

int main(void) {
    CHECK_OK(scratch_node_start(&node, cv_mock_backend(), 2, false));
    CHECK_OK(cv_metrics_server_start(node.node, &(cv_metrics_server_config){ .address = "127.0.0.1" }, &metrics));
    CHECK(cv_metrics_server_port(metrics) > 0);
    CHECK_RESULT(cv_metrics_server_start(node.node, &(cv_metrics_server_config){ .address = "localhost" },
                                         &(cv_metrics_server *){ 0 }),
                 CV_ERROR_INVALID_ARGUMENT); /* numeric addresses only */
    idle_connections();
    guarded_server();

    /* Before any session: everything 0, both devices listed. */
    char *text = scrape();
    CHECK(text != NULL);
    if (text) {
        CHECK_SAMPLE(text, "corvid_node_sessions_total", 0);
        CHECK_SAMPLE(text, "corvid_node_submissions_total", 0);
        CHECK_SAMPLE(text, "corvid_node_device_memory_bytes{device=\"mock0\"}", 0);
        CHECK_SAMPLE(text, "corvid_node_device_memory_bytes{device=\"mock1\"}", 0);
        CHECK(strstr(text, "# TYPE corvid_node_gpu_pass_seconds histogram\n") != NULL);
        CHECK(strstr(text, "corvid_node_gpu_pass_seconds_bucket") == NULL); /* no pass seen yet */
    }
    free(text);

    uint8_t *big = malloc(BIG);
    for (uint32_t i = 0; big && i < BIG; i++)
        big[i] = (uint8_t)(i * 31 + (i >> 9));
    cv_context *ctx = NULL;
    CHECK_OK(cv_context_create(NULL, &ctx));
    cv_device *dev0 = proxy_device(ctx, "0"), *dev1 = proxy_device(ctx, "1");
    cv_proxy_stats s0 = { 0 }, s1 = { 0 };
    if (dev0 && dev1 && big) {
        work_on_mock0(ctx, dev0, big);
        work_on_mock1(ctx, dev1, big);
        CHECK_OK(cv_proxy_get_stats(dev0, &s0));
        CHECK_OK(cv_proxy_get_stats(dev1, &s1));
        CHECK_EQ_INT(s1.upload_bytes_skipped, BIG);
    }

    /* Both sessions live. */
    text = scrape();
    CHECK(text != NULL);
    if (text) {
        CHECK_SAMPLE(text, "corvid_node_sessions_active", 2);
        CHECK_SAMPLE(text, "corvid_node_sessions_total", 2);
        CHECK_SAMPLE(text, "corvid_node_draining", 0);
        CHECK_SAMPLE(text, "corvid_node_submissions_total", SUBMISSIONS);
        CHECK_SAMPLE(text, "corvid_node_errors_total", 0);
        CHECK_SAMPLE(text, "corvid_node_messages_received_total", s0.messages_sent + s1.messages_sent);
        CHECK_SAMPLE(text, "corvid_node_bytes_received_total", s0.bytes_sent + s1.bytes_sent);
        CHECK_SAMPLE(text, "corvid_node_bytes_sent_total", s0.bytes_received + s1.bytes_received);
        CHECK_SAMPLE(text, "corvid_node_cache_misses_total", 1); /* mock0's query */
        CHECK_SAMPLE(text, "corvid_node_cache_hits_total", 1);   /* mock1's query */
        CHECK_SAMPLE(text, "corvid_node_cache_bytes", BIG);
        CHECK_SAMPLE(text, "corvid_node_device_memory_bytes{device=\"mock0\"}", 2 * 4096 + BIG + 16 * 16 * 4);
        CHECK_SAMPLE(text, "corvid_node_device_memory_bytes{device=\"mock1\"}", 512);
        CHECK_SAMPLE(text, "corvid_node_gpu_pass_seconds_count{pass=\"frame\"}", SUBMISSIONS);
        CHECK_SAMPLE(text, "corvid_node_gpu_pass_seconds_bucket{pass=\"frame\",le=\"+Inf\"}", SUBMISSIONS);
        CHECK_SAMPLE(text, "corvid_node_gpu_pass_seconds_bucket{pass=\"frame\",le=\"10\"}", SUBMISSIONS);
        CHECK(sample(text, "corvid_node_gpu_pass_seconds_sum{pass=\"frame\"}") >= 0);
        CHECK_SAMPLE(text, "corvid_node_node_loss_events_total", 0);
        CHECK(strstr(text, "# HELP corvid_node_submissions_total ") != NULL);
        CHECK(strstr(text, "# TYPE corvid_node_submissions_total counter\n") != NULL);
        CHECK(strstr(text, "# TYPE corvid_node_sessions_active gauge\n") != NULL);
        check_promtool(text);
    }
    free(text);

    /* The sessions end: gauges back to 0, counters kept. */
    cv_context_destroy(ctx);
    free(big);
    CHECK_EQ_INT(scratch_node_wait_sessions(&node, 5000), 0);
    text = scrape();
    CHECK(text != NULL);
    if (text) {
        CHECK_SAMPLE(text, "corvid_node_sessions_active", 0);
        CHECK_SAMPLE(text, "corvid_node_sessions_total", 2);
        CHECK_SAMPLE(text, "corvid_node_submissions_total", SUBMISSIONS);
        CHECK_SAMPLE(text, "corvid_node_errors_total", 0);
        CHECK_SAMPLE(text, "corvid_node_device_memory_bytes{device=\"mock0\"}", 0);
        CHECK_SAMPLE(text, "corvid_node_device_memory_bytes{device=\"mock1\"}", 0);
        /* Nothing moves now: the HTTP body is exactly the text the node renders. */
        size_t need = cv_node_metrics_text(node.node, NULL, 0);
        CHECK_EQ_INT(need, strlen(text));
        char *direct = malloc(need + 1);
        CHECK(direct && cv_node_metrics_text(node.node, direct, need + 1) == need);
        CHECK(direct && strcmp(direct, text) == 0);
        char small[64];
        CHECK_EQ_INT(cv_node_metrics_text(node.node, small, sizeof(small)), need); /* snprintf-style */
        CHECK_EQ_INT(strlen(small), sizeof(small) - 1);
        CHECK(direct && strncmp(small, direct, sizeof(small) - 1) == 0);
        free(direct);
        check_promtool(text);
    }
    free(text);

    /* Only GET/HEAD /metrics; the exposition format's content type. */
    http_answer a;
    CHECK(http_request("GET", "/metrics", &a));
    CHECK(strstr(a.content_type, "text/plain") && strstr(a.content_type, "version=0.0.4"));
    free(a.body);
    CHECK(http_request("GET", "/", &a));
    CHECK_EQ_INT(a.status, 404);
    free(a.body);
    CHECK(http_request("GET", "/metrics/x", &a));
    CHECK_EQ_INT(a.status, 404);
    free(a.body);
    CHECK(http_request("POST", "/metrics", &a));
    CHECK_EQ_INT(a.status, 405);
    free(a.body);

    /* Draining shows. */
    cv_node_drain(node.node);
    text = scrape();
    CHECK(text && sample(text, "corvid_node_draining") == 1);
    free(text);

    cv_metrics_server_stop(metrics);
    CHECK_EQ_INT(cv_node_get_stats(node.node).sessions_active, 0);
    scratch_node_stop(&node);
    CHECK_NOTHING_LIVE();
    return check_report("node_metrics");
}
