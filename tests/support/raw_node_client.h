/* A raw node.proto client for tests that speak to corvid-node by hand (no
 * proxy backend, which would refuse most hostile input before sending it):
 * open a session stream, send ClientMessages, read NodeMessages, and expect
 * a Reply, a Completed or the end of the stream with a given status. Sends are
 * not checked (a refused stream fails them; what the receive side says is). */
#ifndef CORVID_TEST_RAW_NODE_CLIENT_H
#define CORVID_TEST_RAW_NODE_CLIENT_H

#include "corvid/context.h"
#include "corvid/node_protocol.h"
#include "corvid/rpc.h"

#define RAW_TIMEOUT_MS 5000u

typedef struct raw_client {
    cv_rpc_client *client;
    cv_rpc_stream *stream;
    uint64_t seq;
} raw_client;

/* Opens a session stream (cc NULL: the node's message limit, defaults otherwise). */
void raw_open_with(raw_client *c, const char *endpoint, const cv_rpc_client_config *cc, const cv_rpc_metadata *md,
                   uint32_t count);
void raw_open(raw_client *c, const char *endpoint);
void raw_close(raw_client *c);

/* Numbers and sends m; returns its seq. */
uint64_t raw_send(raw_client *c, Corvid__ClientMessage *m);
/* The next message (NULL at the end of the stream or on error); free with corvid__node_message__free_unpacked. */
Corvid__NodeMessage *raw_recv(raw_client *c);

void raw_expect_end(raw_client *c, int status, const char *needle, int line);
void raw_expect_reply(raw_client *c, uint64_t seq, cv_result code, const char *needle, int line);
void raw_expect_completed(raw_client *c, uint64_t ticket, cv_result code, const char *needle, int line);
#define EXPECT_END(c, status, needle) raw_expect_end(c, status, needle, __LINE__)
#define EXPECT_REPLY(c, seq, code, needle) raw_expect_reply(c, seq, code, needle, __LINE__)
#define EXPECT_COMPLETED(c, ticket, code, needle) raw_expect_completed(c, ticket, code, needle, __LINE__)

uint64_t raw_send_hello(raw_client *c, uint32_t version, uint32_t device, const char *client_name);
/* desc NULL: a command list. */
uint64_t raw_send_create(raw_client *c, uint64_t id, const cv_resource_desc *desc);
uint64_t raw_send_destroy(raw_client *c, uint64_t id);
uint64_t raw_send_write(raw_client *c, uint64_t id, uint64_t offset, const void *data, size_t size);
uint64_t raw_send_read(raw_client *c, uint64_t id, uint64_t offset, uint64_t size);
/* Reads size bytes at offset 0 back in one piece; false unless they came. */
bool raw_read_back(raw_client *c, uint64_t id, uint64_t size, uint8_t *out);
uint64_t raw_send_chunk(raw_client *c, const uint8_t sha[32], uint64_t size, uint64_t offset, const void *data,
                        size_t len);
uint64_t raw_send_blob_write(raw_client *c, uint64_t id, const uint8_t sha[32]);
uint64_t raw_send_compile(raw_client *c, uint64_t id, const uint8_t *encoded, size_t size);
uint64_t raw_send_submit(raw_client *c, uint64_t id, uint64_t ticket);
/* A one-command list copying size bytes from src to dst (client ids), encoded (free *out). */
void raw_encode_copy(uint64_t src, uint64_t dst, uint64_t size, uint8_t **out, size_t *out_size);

#endif
