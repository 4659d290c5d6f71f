/* Cluster membership: the nodes this node may send partitions to.
 *
 * A client names where a node pushes a transfer (PushTransfer.destination), so
 * without a check a client could make the node connect anywhere: any host:port
 * (presenting the node's peer token there), a unix socket, or a name that sends
 * the node to DNS. The node therefore sends only to its cluster's members, a
 * list its operator gives (cv_node_config.peers, corvid-node --peers). Every
 * address is normalised the same way (peer_address_normalize) before the two
 * are compared, and nothing is resolved before the check: a destination that
 * is not a member is refused with a message saying so, before any connection.
 *
 * With no list, a node that listens on loopback (or a unix socket) may send to
 * loopback addresses only: its clients already run on this machine and can
 * reach those addresses themselves, so the node gives them no reach they lack
 * (that keeps deploy/local-cluster.sh and the tests, whose ports are picked at
 * start, working); a node listening on a network address sends to no one.
 *
 *     peer_members *m;
 *     if (peer_members_create("node0:7700,10.0.0.2:7700", "peers", false, &m) != CV_OK) ... // names the entry
 *     char target[PEER_ADDRESS_MAX];
 *     if (peer_members_check(m, destination, target, sizeof(target)) == CV_OK)
 *         connect to target ("dns:///node0:7700": canonical, never read as a unix: or other URI)
 *     peer_members_destroy(m);
 *
 * Immutable after creation: any thread may check. */
#ifndef CORVID_NODE_PEER_MEMBERS_H
#define CORVID_NODE_PEER_MEMBERS_H

#include <stdbool.h>
#include <stddef.h>

#include "corvid/result.h"

/* A canonical "host:port" (a 253-character name, brackets, colon, 5 digits) fits, as does "dns:///" before it. */
#define PEER_ADDRESS_MAX 280u
/* Members at most. */
#define PEER_MEMBERS_MAX 256u

typedef struct peer_members peer_members;

/* "host:port" (the syntax of corvid/endpoint.h) -> its canonical form in out: an IPv4 address as a dotted
 * quad, an IPv6 address as inet_ntop writes it in brackets (an IPv4-mapped one as IPv4), a name in lower
 * case, the port in decimal without leading zeros (1..65535). Refused with CV_ERROR_MALFORMED, the message
 * "<what>: '<address>': why": no port, a unix:, unix-abstract:, vsock: or other URI target, an IPv6 address
 * without brackets, a numeric shorthand ("127.1") that a resolver would read as an address, a name that is
 * not letters, digits, '-' and '_' in dot-separated labels of 1..63 characters. Nothing is resolved. */
cv_result peer_address_normalize(const char *address, const char *what, char *out, size_t cap);

/* list: comma-separated "host:port" (spaces around entries ignored), or NULL for none (then loopback_only
 * decides: loopback destinations only, or none). CV_ERROR_MALFORMED names `what` (the option), the entry
 * and why; CV_ERROR_LIMIT_EXCEEDED past PEER_MEMBERS_MAX entries. */
cv_result peer_members_create(const char *list, const char *what, bool loopback_only, peer_members **out);
void peer_members_destroy(peer_members *m);

/* CV_OK if this node may send to `destination`: target gets the channel target to dial ("dns:///" and the
 * canonical address). Else CV_ERROR_MALFORMED (not a host:port) or CV_ERROR_INVALID_ARGUMENT (not a member),
 * the message naming push_transfer.destination, the address and the node's list. */
cv_result peer_members_check(const peer_members *m, const char *destination, char *target, size_t cap);

#endif
