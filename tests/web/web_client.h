/* A small blocking HTTP/1.1 and WebSocket client for the web server's tests:
 * one request per connection, and a WebSocket that sends masked text and reads
 * frames. Only what the tests need; the server under test is libwebsockets. */
#ifndef CORVID_TEST_WEB_CLIENT_H
#define CORVID_TEST_WEB_CLIENT_H

#include <stddef.h>
#include <stdint.h>

typedef struct web_reply {
    int status;
    char headers[4096];
    uint8_t *body; /* malloc'd, NUL-terminated */
    size_t body_size;
} web_reply;

/* Sends `method path` with optional extra header lines ("Name: value\r\n" ...) and body;
 * returns 0 and fills *out, or -1. */
int web_request(uint16_t port, const char *method, const char *path, const char *headers, const void *body,
                size_t body_size, web_reply *out);
void web_reply_free(web_reply *r);

/* A WebSocket: web_ws_connect returns the socket (>= 0) after a 101, or -status
 * of the refusal (e.g. -401), or -1. */
int web_ws_connect(uint16_t port, const char *path_and_query);
int web_ws_send_text(int fd, const char *text);
/* Reads one message: *opcode 1 text, 2 binary, 8 close. Returns its size or -1. */
long web_ws_read(int fd, int *opcode, uint8_t *buf, size_t cap);

#endif
