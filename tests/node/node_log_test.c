/* corvid-node's log (server/node/node_log.h) against hostile clients.
 *
 * cv_log_escape is checked byte for byte. Then a node with mock devices logs into
 * a sink of this test: a client whose name and buffer label carry newlines,
 * carriage returns, terminal escapes and bytes that are not UTF-8 gets exactly
 * the escaped log lines, and no forged one (every captured line is printable
 * ASCII); the error reply naming the label is escaped the same way; a flood of
 * failing requests is rate-limited, and what was held back is counted in
 * "(K more request-error lines suppressed)" lines that add up; ending the
 * sessions of a draining node (cv_node_cancel_sessions) tells the client and the
 * log why. */
#include <inttypes.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "node_log.h"
#include "raw_node_client.h"
#include "scratch_node.h"

#define FLOOD 100
#define MAX_LINES 4096

static struct {
    pthread_mutex_t lock;
    char *lines[MAX_LINES];
    uint32_t count;
} captured = { .lock = PTHREAD_MUTEX_INITIALIZER };

static void sink(const char *line, void *user) {
    (void)user;
    pthread_mutex_lock(&captured.lock);
    if (captured.count < MAX_LINES)
        captured.lines[captured.count++] = strdup(line);
    pthread_mutex_unlock(&captured.lock);
}

/* The captured line containing `needle` (NULL if none; reported). */
static const char *line_with(const char *needle) {
    const char *found = NULL;
    pthread_mutex_lock(&captured.lock);
    for (uint32_t i = 0; i < captured.count && !found; i++)
        if (captured.lines[i] && strstr(captured.lines[i], needle))
            found = captured.lines[i];
    pthread_mutex_unlock(&captured.lock);
    if (!found)
        fprintf(stderr, "no log line contains '%s'\n", needle);
    return found;
}

static bool ends_with(const char *s, const char *tail) {
    size_t n = strlen(s), t = strlen(tail);
    return n >= t && strcmp(s + n - t, tail) == 0;
}

#define CHECK_ESCAPE(in, expected) \
    do { \
        char out_[256]; \
        size_t n_ = cv_log_escape(out_, sizeof(out_), in); \
        if (strcmp(out_, expected) != 0) \
            fprintf(stderr, "escape: got '%s', expected '%s'\n", out_, expected); \
        CHECK(strcmp(out_, expected) == 0); \
        CHECK_EQ_INT(n_, strlen(expected)); \
    } while (0)

static void escape_cases(void) {
    CHECK_ESCAPE("plain text: ok", "plain text: ok");
    CHECK_ESCAPE("a\nb", "a\\nb");
    CHECK_ESCAPE("\r\t\\", "\\r\\t\\\\");
    CHECK_ESCAPE("\x1b[31mred", "\\x1b[31mred");
    CHECK_ESCAPE("\x7f\x01", "\\x7f\\x01");
    CHECK_ESCAPE("\xff\xc3\x28", "\\xff\\xc3(");                         /* not UTF-8 */
    CHECK_ESCAPE("\xc0\xaf \xed\xa0\x80", "\\xc0\\xaf \\xed\\xa0\\x80"); /* overlong, a surrogate */
    CHECK_ESCAPE(
        "\xc2\x9b"
        "2J",
        "\\xc2\\x9b2J"); /* C1 CSI */
    CHECK_ESCAPE("caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80", "caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80");
    CHECK_ESCAPE("\xe2\x82", "\\xe2\\x82"); /* cut short */
    char small[4];
    CHECK_EQ_INT(cv_log_escape(small, sizeof(small), "ab\ncd"), 2); /* "\n" would not fit whole */
    CHECK(strcmp(small, "ab") == 0);
    CHECK_EQ_INT(cv_log_escape(small, sizeof(small), NULL), 0);
}

/* Every captured line is one line of printable ASCII: nothing of a client got through raw. */
static void check_printable(void) {
    pthread_mutex_lock(&captured.lock);
    for (uint32_t i = 0; i < captured.count; i++)
        for (const unsigned char *p = (const unsigned char *)captured.lines[i]; p && *p; p++)
            if (*p < 0x20 || *p >= 0x7f) {
                fprintf(stderr, "log line %u has byte 0x%02x: %s\n", i, *p, captured.lines[i]);
                CHECK(false);
                break;
            }
    pthread_mutex_unlock(&captured.lock);
}

/* Request-error lines written, and those the summaries say were suppressed. */
static void count_request_errors(uint64_t *written, uint64_t *suppressed) {
    *written = *suppressed = 0;
    pthread_mutex_lock(&captured.lock);
    for (uint32_t i = 0; i < captured.count; i++) {
        uint64_t k = 0;
        if (strstr(captured.lines[i], "): request "))
            (*written)++;
        else if (sscanf(captured.lines[i], "corvid-node: (%" SCNu64 " more request-error lines suppressed)", &k) == 1)
            *suppressed += k;
    }
    pthread_mutex_unlock(&captured.lock);
}

int main(void) {
    escape_cases();

    scratch_node node;
    cv_node_config cfg = { .log_sessions = true, .log_sink = sink };
    CHECK_OK(scratch_node_start_secured(&node, cv_mock_backend(), 1, &cfg));

    /* A client name that would forge a line and colour the terminal. */
    raw_client c;
    raw_open(&c, node.endpoint);
    raw_send_hello(&c, CV_NODE_PROTOCOL_VERSION, 0, "evil\ncorvid-node: session 9 (x): forged\r\x1b[31m\xff");
    Corvid__NodeMessage *m = raw_recv(&c);
    CHECK(m && m->msg_case == CORVID__NODE_MESSAGE__MSG_HELLO);
    if (m)
        corvid__node_message__free_unpacked(m, NULL);
    const char *hello = line_with("): client '");
    CHECK(hello && strncmp(hello, "corvid-node: session 1 (ipv4:127.0.0.1:", 39) == 0);
    CHECK(hello &&
          ends_with(hello,
                    "): client 'evil\\ncorvid-node: session 9 (x): forged\\r\\x1b[31m\\xff' on device 0 (mock0)"));
    CHECK(line_with("forged") == hello); /* the only line that says it */

    /* A label in an error: the reply and the log line carry it escaped. */
    uint64_t id = cv_handle_pack(CV_HANDLE_BUFFER, 1, 1, 1);
    cv_resource_desc desc = { .type = CV_HANDLE_BUFFER, .buffer = { .size = 256 } };
    snprintf(desc.buffer.label, sizeof(desc.buffer.label), "%s", "buf\n\x1b[2Jx\xfe");
    EXPECT_REPLY(&c, raw_send_create(&c, id, &desc), CV_OK, NULL);
    uint64_t seq = raw_send_read(&c, id, 0, 512);
    EXPECT_REPLY(&c, seq, CV_ERROR_OUT_OF_RANGE, "of buffer 'buf\\n\\x1b[2Jx\\xfe' (256 bytes)");
    char expected[256];
    snprintf(expected, sizeof(expected),
             "): request %" PRIu64
             ": CV_ERROR_OUT_OF_RANGE: read_buffer: 512 bytes at offset 0 of buffer "
             "'buf\\n\\x1b[2Jx\\xfe' (256 bytes)",
             seq);
    const char *refused = line_with(expected);
    CHECK(refused && ends_with(refused, expected));

    /* A flood of failing requests: rate-limited, nothing lost from the count. */
    for (int i = 0; i < FLOOD; i++)
        raw_send_destroy(&c, cv_handle_pack(CV_HANDLE_BUFFER, 1, 1, 1000 + (uint32_t)i));
    for (int i = 0; i < FLOOD; i++) {
        m = raw_recv(&c);
        CHECK(m && m->msg_case == CORVID__NODE_MESSAGE__MSG_REPLY && m->reply->result != CV_OK);
        if (m)
            corvid__node_message__free_unpacked(m, NULL);
    }

    /* The node drains and its time runs out: the client and the log say so. */
    cv_node_drain(node.node);
    CHECK_EQ_INT(cv_node_wait_sessions(node.node, 50), 1);
    cv_node_cancel_sessions(node.node, "drain timeout (2 s) expired");
    EXPECT_END(&c, CV_RPC_STATUS_UNAVAILABLE, "node shutting down: drain timeout (2 s) expired");
    CHECK_EQ_INT(cv_node_wait_sessions(node.node, 5000), 0);
    const char *ended = line_with("): ended: ");
    CHECK(ended && ends_with(ended, "): ended: drain timeout (2 s) expired"));
    raw_close(&c);
    scratch_node_stop(&node); /* writes the last summaries */

    uint64_t written = 0, suppressed = 0;
    count_request_errors(&written, &suppressed);
    printf("node_log: %" PRIu64 " request-error lines written, %" PRIu64 " suppressed\n", written, suppressed);
    CHECK_EQ_INT(written + suppressed, FLOOD + 1);
    CHECK(suppressed > 0);
    check_printable();

    for (uint32_t i = 0; i < captured.count; i++)
        free(captured.lines[i]);
    CHECK_NOTHING_LIVE();
    return check_report("node_log");
}
