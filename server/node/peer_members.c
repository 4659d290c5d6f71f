/* Cluster membership (peer_members.h): address normalisation and the check
 * every PushTransfer destination passes before the node connects anywhere. */
#include "peer_members.h"

#include <arpa/inet.h>
#include <ctype.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct peer_members {
    bool loopback_only; /* no list: loopback destinations only (else none) */
    uint32_t count;
    char (*addresses)[PEER_ADDRESS_MAX]; /* canonical */
    char list[512];                      /* for messages: the members, canonical, possibly cut short */
    bool list_cut;
};

/* 1..65535, decimal digits only. */
static bool parse_port(const char *text, unsigned *port) {
    size_t n = strlen(text);
    if (n == 0 || n > 5)
        return false;
    unsigned v = 0;
    for (size_t i = 0; i < n; i++) {
        if (!isdigit((unsigned char)text[i]))
            return false;
        v = v * 10 + (unsigned)(text[i] - '0');
    }
    *port = v;
    return v >= 1 && v <= 65535;
}

/* A DNS name: dot-separated labels of letters, digits, '-' (not first or last) and '_', 1..63 each. */
static bool valid_name(const char *host) {
    size_t n = strlen(host), label = 0;
    if (n == 0 || n > 253)
        return false;
    for (size_t i = 0; i <= n; i++) {
        char c = host[i];
        if (c == '.' || c == '\0') {
            if (label == 0 || label > 63 || host[i - 1] == '-')
                return false;
            label = 0;
            continue;
        }
        if (!isalnum((unsigned char)c) && c != '-' && c != '_')
            return false;
        if (c == '-' && label == 0)
            return false;
        label++;
    }
    return true;
}

/* The canonical text of a host (no port): IPv4, [IPv6] or a lower-case name. */
static cv_result normalize_host(const char *host, bool bracketed, char *out, size_t cap) {
    struct in_addr v4;
    struct in6_addr v6;
    char text[INET6_ADDRSTRLEN];
    if (bracketed) {
        if (inet_pton(AF_INET6, host, &v6) != 1)
            return cv_error(CV_ERROR_MALFORMED, "'[%s]' is not an IPv6 address", host);
        if (IN6_IS_ADDR_V4MAPPED(&v6)) {
            memcpy(&v4, &v6.s6_addr[12], 4);
            inet_ntop(AF_INET, &v4, text, sizeof(text));
            snprintf(out, cap, "%s", text);
        } else {
            inet_ntop(AF_INET6, &v6, text, sizeof(text));
            snprintf(out, cap, "[%s]", text);
        }
        return CV_OK;
    }
    if (strchr(host, ':'))
        return cv_error(CV_ERROR_MALFORMED, "an IPv6 address needs brackets ([::1]:7700)");
    if (inet_pton(AF_INET, host, &v4) == 1) {
        inet_ntop(AF_INET, &v4, text, sizeof(text));
        snprintf(out, cap, "%s", text);
        return CV_OK;
    }
    /* inet_aton takes "127.1", "0x7f.1" or "2130706433" as addresses, and so do resolvers: only a dotted quad
     * is an address here, so that two spellings of one address cannot differ by the comparison. */
    if (inet_aton(host, &v4) != 0)
        return cv_error(CV_ERROR_MALFORMED, "'%s' is a numeric shorthand: write the address as a dotted quad", host);
    if (!valid_name(host))
        return cv_error(CV_ERROR_MALFORMED,
                        "'%.64s' is not a host name (labels of letters, digits, '-' and '_', 1..63 characters, "
                        "separated by dots)",
                        host);
    size_t n = strlen(host);
    if (n >= cap)
        return cv_error(CV_ERROR_MALFORMED, "host name too long");
    for (size_t i = 0; i <= n; i++)
        out[i] = (char)tolower((unsigned char)host[i]);
    return CV_OK;
}

cv_result peer_address_normalize(const char *address, char *out, size_t cap) {
    if (cap)
        out[0] = '\0';
    if (!address || !address[0])
        return cv_error(CV_ERROR_MALFORMED, "empty (a peer is host:port)");
    size_t n = strlen(address);
    if (n > 255)
        return cv_error(CV_ERROR_MALFORMED, "longer than 255 characters");
    static const char *const schemes[] = { "unix:", "unix-abstract:", "vsock:", "ipv4:", "ipv6:", "dns:" };
    for (size_t i = 0; i < sizeof(schemes) / sizeof(schemes[0]); i++)
        if (strncmp(address, schemes[i], strlen(schemes[i])) == 0)
            return cv_error(CV_ERROR_MALFORMED,
                            "a '%.*s' target, not host:port (peers are reached over TCP at host:port only)",
                            (int)strlen(schemes[i]) - 1, schemes[i]);
    if (strchr(address, '/'))
        return cv_error(CV_ERROR_MALFORMED, "a URI or path, not host:port");
    char host[256];
    const char *port_text;
    bool bracketed = address[0] == '[';
    if (bracketed) {
        const char *end = strchr(address, ']');
        if (!end || end[1] != ':')
            return cv_error(CV_ERROR_MALFORMED, "not [IPv6]:port");
        snprintf(host, sizeof(host), "%.*s", (int)(end - address - 1), address + 1);
        port_text = end + 2;
    } else {
        const char *colon = strrchr(address, ':');
        if (!colon)
            return cv_error(CV_ERROR_MALFORMED, "no port (a peer is host:port)");
        snprintf(host, sizeof(host), "%.*s", (int)(colon - address), address);
        port_text = colon + 1;
    }
    unsigned port;
    if (!parse_port(port_text, &port))
        return cv_error(CV_ERROR_MALFORMED, "port '%.16s' is not a number in 1..65535", port_text);
    char canonical[PEER_ADDRESS_MAX];
    cv_result r = normalize_host(host, bracketed, canonical, sizeof(canonical) - 8);
    if (r != CV_OK)
        return r;
    if ((size_t)snprintf(out, cap, "%s:%u", canonical, port) >= cap)
        return cv_error(CV_ERROR_MALFORMED, "too long");
    return CV_OK;
}

static cv_result add_member(peer_members *m, const char *entry) {
    char canonical[PEER_ADDRESS_MAX];
    if (peer_address_normalize(entry, canonical, sizeof(canonical)) != CV_OK)
        return cv_error(CV_ERROR_MALFORMED, "peer '%.255s': %s", entry, cv_last_error());
    for (uint32_t i = 0; i < m->count; i++)
        if (strcmp(m->addresses[i], canonical) == 0)
            return CV_OK;
    if (m->count == PEER_MEMBERS_MAX)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "peers: more than %u", PEER_MEMBERS_MAX);
    snprintf(m->addresses[m->count++], PEER_ADDRESS_MAX, "%s", canonical);
    size_t used = strlen(m->list);
    if (!m->list_cut && used + strlen(canonical) + 6 < sizeof(m->list))
        snprintf(m->list + used, sizeof(m->list) - used, "%s%s", used ? "," : "", canonical);
    else if (!m->list_cut) {
        snprintf(m->list + used, sizeof(m->list) - used, ",...");
        m->list_cut = true;
    }
    return CV_OK;
}

cv_result peer_members_create(const char *list, bool loopback_only, peer_members **out) {
    *out = NULL;
    peer_members *m = calloc(1, sizeof(*m));
    if (!m)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "peers");
    m->loopback_only = loopback_only;
    if (!list) {
        *out = m;
        return CV_OK;
    }
    m->addresses = calloc(PEER_MEMBERS_MAX, sizeof(*m->addresses));
    if (!m->addresses) {
        free(m);
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "peers");
    }
    cv_result r = CV_OK;
    const char *p = list;
    for (;;) {
        const char *comma = strchr(p, ',');
        size_t len = comma ? (size_t)(comma - p) : strlen(p);
        while (len && isspace((unsigned char)*p)) {
            p++;
            len--;
        }
        while (len && isspace((unsigned char)p[len - 1]))
            len--;
        char entry[300];
        snprintf(entry, sizeof(entry), "%.*s", len < 299 ? (int)len : 299, p);
        r = add_member(m, entry);
        if (r != CV_OK || !comma)
            break;
        p = comma + 1;
    }
    if (r != CV_OK) {
        peer_members_destroy(m);
        return r;
    }
    *out = m;
    return CV_OK;
}

void peer_members_destroy(peer_members *m) {
    if (!m)
        return;
    free(m->addresses);
    free(m);
}

/* Canonical forms only: 127.0.0.0/8, [::1], localhost. */
static bool is_loopback(const char *canonical) {
    return strncmp(canonical, "127.", 4) == 0 || strncmp(canonical, "[::1]:", 6) == 0 ||
           strncmp(canonical, "localhost:", 10) == 0;
}

cv_result peer_members_check(const peer_members *m, const char *destination, char *target, size_t cap) {
    if (cap)
        target[0] = '\0';
    char canonical[PEER_ADDRESS_MAX];
    if (peer_address_normalize(destination, canonical, sizeof(canonical)) != CV_OK)
        return cv_error(CV_ERROR_MALFORMED, "push_transfer.destination '%.255s': %s; refused, nothing sent",
                        destination ? destination : "", cv_last_error());
    bool member = false;
    if (m->addresses)
        for (uint32_t i = 0; !member && i < m->count; i++)
            member = strcmp(m->addresses[i], canonical) == 0;
    else
        member = m->loopback_only && is_loopback(canonical);
    if (member) {
        snprintf(target, cap, "dns:///%s", canonical);
        return CV_OK;
    }
    if (m->addresses)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "push_transfer.destination '%s' is not a peer of this node (corvid-node --peers %s); "
                        "refused, nothing sent",
                        canonical, m->list);
    if (m->loopback_only)
        return cv_error(CV_ERROR_INVALID_ARGUMENT,
                        "push_transfer.destination '%s': this node has no --peers, so it sends transfers to "
                        "loopback addresses only (127.0.0.0/8, [::1], localhost); list the cluster's nodes with "
                        "corvid-node --peers HOST:PORT,...; refused, nothing sent",
                        canonical);
    return cv_error(CV_ERROR_INVALID_ARGUMENT,
                    "push_transfer.destination '%s': this node listens on a network address and has no --peers, "
                    "so it sends transfers to no node; list the cluster's nodes with corvid-node --peers "
                    "HOST:PORT,...; refused, nothing sent",
                    canonical);
}
