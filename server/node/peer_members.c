/* Cluster membership (peer_members.h): address normalisation and the check
 * every PushTransfer destination passes before the node connects anywhere. */
#include "peer_members.h"

#include "corvid/endpoint.h"

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

/* The canonical text of a host (no port; IPv6 without its brackets): IPv4, [IPv6] or a lower-case name. */
static cv_result normalize_host(const char *host, bool bracketed, const char *what, const char *address, char *out,
                                size_t cap) {
    struct in_addr v4;
    struct in6_addr v6;
    char text[INET6_ADDRSTRLEN];
    if (bracketed) {
        if (inet_pton(AF_INET6, host, &v6) != 1)
            return cv_error(CV_ERROR_MALFORMED, "%s: '%s': '[%s]' is not an IPv6 address", what, address, host);
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
    if (inet_pton(AF_INET, host, &v4) == 1) {
        inet_ntop(AF_INET, &v4, text, sizeof(text));
        snprintf(out, cap, "%s", text);
        return CV_OK;
    }
    /* inet_aton takes "127.1", "0x7f.1" or "2130706433" as addresses, and so do resolvers: only a dotted quad
     * is an address here, so that two spellings of one address cannot differ by the comparison. */
    if (inet_aton(host, &v4) != 0)
        return cv_error(CV_ERROR_MALFORMED,
                        "%s: '%s': '%s' is a numeric shorthand: write the address as a dotted quad", what, address,
                        host);
    if (!valid_name(host))
        return cv_error(CV_ERROR_MALFORMED,
                        "%s: '%s': '%s' is not a host name (labels of letters, digits, '-' and '_', 1..63 "
                        "characters, separated by dots)",
                        what, address, host);
    size_t n = strlen(host);
    if (n >= cap)
        return cv_error(CV_ERROR_MALFORMED, "%s: '%s': host name too long", what, address);
    for (size_t i = 0; i <= n; i++)
        out[i] = (char)tolower((unsigned char)host[i]);
    return CV_OK;
}

cv_result peer_address_normalize(const char *address, const char *what, char *out, size_t cap) {
    if (cap)
        out[0] = '\0';
    if (!address)
        address = "";
    static const char *const schemes[] = { "unix:", "unix-abstract:", "vsock:", "ipv4:", "ipv6:", "dns:" };
    for (size_t i = 0; i < sizeof(schemes) / sizeof(schemes[0]); i++)
        if (strncmp(address, schemes[i], strlen(schemes[i])) == 0)
            return cv_error(CV_ERROR_MALFORMED,
                            "%s: '%.255s': a '%.*s' target, not HOST:PORT (peers are reached over TCP at "
                            "HOST:PORT only)",
                            what, address, (int)strlen(schemes[i]) - 1, schemes[i]);
    if (strchr(address, '/'))
        return cv_error(CV_ERROR_MALFORMED, "%s: '%.255s': a URI or path, not HOST:PORT", what, address);
    cv_endpoint e;
    if (cv_endpoint_parse(address, what, &e) != CV_OK)
        return cv_error(CV_ERROR_MALFORMED, "%s", cv_last_error());
    bool bracketed = e.host[0] == '[';
    char host[CV_ENDPOINT_HOST_MAX + 3], canonical[PEER_ADDRESS_MAX];
    snprintf(host, sizeof(host), "%.*s", bracketed ? (int)strlen(e.host) - 2 : (int)strlen(e.host),
             e.host + (bracketed ? 1 : 0));
    cv_result r = normalize_host(host, bracketed, what, address, canonical, sizeof(canonical) - 8);
    if (r != CV_OK)
        return r;
    snprintf(out, cap, "%s:%u", canonical, (unsigned)e.port);
    return CV_OK;
}

static cv_result add_member(peer_members *m, const char *entry, const char *what) {
    char canonical[PEER_ADDRESS_MAX];
    cv_result r = peer_address_normalize(entry, what, canonical, sizeof(canonical));
    if (r != CV_OK)
        return r;
    for (uint32_t i = 0; i < m->count; i++)
        if (strcmp(m->addresses[i], canonical) == 0)
            return CV_OK;
    if (m->count == PEER_MEMBERS_MAX)
        return cv_error(CV_ERROR_LIMIT_EXCEEDED, "%s: more than %u peers", what, PEER_MEMBERS_MAX);
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

cv_result peer_members_create(const char *list, const char *what, bool loopback_only, peer_members **out) {
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
        char entry[CV_ENDPOINT_HOST_MAX + 16];
        if (len >= sizeof(entry)) {
            r = cv_error(CV_ERROR_MALFORMED, "%s: an entry of %zu characters ('%.40s...')", what, len, p);
            break;
        }
        snprintf(entry, sizeof(entry), "%.*s", (int)len, p);
        r = add_member(m, entry, what);
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

/* Canonical forms only: 127.0.0.0/8, [::1], localhost (a name such as "127.example" is not an address). */
static bool is_loopback(const char *canonical) {
    const char *colon = strrchr(canonical, ':');
    char host[PEER_ADDRESS_MAX];
    snprintf(host, sizeof(host), "%.*s", (int)(colon - canonical), canonical);
    struct in_addr v4;
    if (inet_pton(AF_INET, host, &v4) == 1)
        return (ntohl(v4.s_addr) >> 24) == 127;
    return strcmp(host, "[::1]") == 0 || strcmp(host, "localhost") == 0;
}

cv_result peer_members_check(const peer_members *m, const char *destination, char *target, size_t cap) {
    if (cap)
        target[0] = '\0';
    char canonical[PEER_ADDRESS_MAX];
    if (peer_address_normalize(destination, "push_transfer.destination", canonical, sizeof(canonical)) != CV_OK)
        return cv_error(CV_ERROR_MALFORMED, "%s; refused, nothing sent", cv_last_error());
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
