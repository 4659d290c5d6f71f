/* Test client of the web server (see web_client.h). */
#include "web_client.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

static int dial(uint16_t port) {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = { .sin_family = AF_INET, .sin_port = htons(port) };
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd < 0 || connect(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        if (fd >= 0)
            close(fd);
        return -1;
    }
    return fd;
}

static int write_all(int fd, const void *p, size_t n) {
    const uint8_t *b = p;
    while (n) {
        ssize_t w = write(fd, b, n);
        if (w <= 0)
            return -1;
        b += w;
        n -= (size_t)w;
    }
    return 0;
}

static int read_all(int fd, void *p, size_t n) {
    uint8_t *b = p;
    while (n) {
        ssize_t r = read(fd, b, n);
        if (r <= 0)
            return -1;
        b += r;
        n -= (size_t)r;
    }
    return 0;
}

/* Reads the status line and headers (up to the blank line) into `head`. */
static int read_head(int fd, char *head, size_t cap, int *status) {
    size_t n = 0;
    while (n + 1 < cap) {
        if (read(fd, head + n, 1) != 1)
            return -1;
        n++;
        head[n] = 0;
        if (n >= 4 && memcmp(head + n - 4, "\r\n\r\n", 4) == 0)
            return sscanf(head, "HTTP/1.%*d %d", status) == 1 ? 0 : -1;
    }
    return -1;
}

int web_request(uint16_t port, const char *method, const char *path, const char *headers, const void *body,
                size_t body_size, web_reply *out) {
    memset(out, 0, sizeof *out);
    int fd = dial(port);
    if (fd < 0)
        return -1;
    char req[4096];
    int n = snprintf(req, sizeof req, "%s %s HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n%s", method, path,
                     headers ? headers : "");
    if (body_size || strcmp(method, "POST") == 0 || strcmp(method, "PUT") == 0)
        n += snprintf(req + n, sizeof req - (size_t)n, "Content-Length: %zu\r\n", body_size);
    n += snprintf(req + n, sizeof req - (size_t)n, "\r\n");
    int rc = -1;
    if (write_all(fd, req, (size_t)n) == 0 && (!body_size || write_all(fd, body, body_size) == 0) &&
        read_head(fd, out->headers, sizeof out->headers, &out->status) == 0) {
        const char *cl = strcasestr(out->headers, "content-length:");
        size_t len = cl ? strtoul(cl + 15, NULL, 10) : 0;
        out->body = malloc(len + 1);
        if (out->body && (strcmp(method, "HEAD") == 0 || read_all(fd, out->body, len) == 0)) {
            out->body_size = strcmp(method, "HEAD") == 0 ? 0 : len;
            out->body[out->body_size] = 0;
            rc = 0;
        }
    }
    close(fd);
    return rc;
}

void web_reply_free(web_reply *r) {
    free(r->body);
    memset(r, 0, sizeof *r);
}

int web_ws_connect(uint16_t port, const char *path_and_query) {
    int fd = dial(port);
    if (fd < 0)
        return -1;
    char req[1024], head[4096];
    int n = snprintf(req, sizeof req,
                     "GET %s HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                     "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n",
                     path_and_query);
    int status = 0;
    if (write_all(fd, req, (size_t)n) != 0 || read_head(fd, head, sizeof head, &status) != 0) {
        close(fd);
        return -1;
    }
    if (status != 101) {
        close(fd);
        return -status;
    }
    return fd;
}

int web_ws_send_text(int fd, const char *text) {
    size_t n = strlen(text);
    uint8_t hdr[14] = { 0x81 };
    size_t h = 2;
    if (n < 126) {
        hdr[1] = (uint8_t)(0x80 | n);
    } else {
        hdr[1] = 0x80 | 126;
        hdr[2] = (uint8_t)(n >> 8);
        hdr[3] = (uint8_t)n;
        h = 4;
    }
    const uint8_t mask[4] = { 1, 2, 3, 4 };
    memcpy(hdr + h, mask, 4);
    h += 4;
    uint8_t *frame = malloc(h + n);
    if (!frame)
        return -1;
    memcpy(frame, hdr, h);
    for (size_t i = 0; i < n; i++)
        frame[h + i] = (uint8_t)text[i] ^ mask[i % 4];
    int rc = write_all(fd, frame, h + n);
    free(frame);
    return rc;
}

long web_ws_read(int fd, int *opcode, uint8_t *buf, size_t cap) {
    uint8_t h[2];
    if (read_all(fd, h, 2) != 0)
        return -1;
    *opcode = h[0] & 0x0f;
    uint64_t n = h[1] & 0x7f;
    uint8_t ext[8];
    if (n == 126) {
        if (read_all(fd, ext, 2) != 0)
            return -1;
        n = (uint64_t)ext[0] << 8 | ext[1];
    } else if (n == 127) {
        if (read_all(fd, ext, 8) != 0)
            return -1;
        n = 0;
        for (int i = 0; i < 8; i++)
            n = n << 8 | ext[i];
    }
    if (n > cap || read_all(fd, buf, (size_t)n) != 0)
        return -1;
    return (long)n;
}
