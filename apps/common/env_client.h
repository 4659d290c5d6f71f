/* The client library's environment, for programs: CORVID_TRANSFER_PATH and the
 * CORVID_NODE_* variables of proxy devices, read into the settings the library
 * takes (transfer.h's cv_transfer_set_path, proxy.h's cv_proxy_options). The
 * library itself never reads the environment.
 *
 *     if (cv_env_client_configure(CV_ENV_CLIENT_ALL) != CV_OK) {  // at the start
 *         fprintf(stderr, "prog: %s\n", cv_last_error()); // names the variable
 *         return 1;
 *     }
 *
 * Variables (unset or empty: the default):
 *   CORVID_TRANSFER_PATH=auto|device|shared|host-import|staged|peer  the path of every transfer
 *   CORVID_NODE_TIMEOUT_MS        one answer from a node (1..86400000, default 120000)
 *   CORVID_NODE_PEER_DEADLINE_MS  how long a node waits for a peer's transfer (default: the node's)
 *   CORVID_NODE_KEEPALIVE_MS      ping interval (100..3600000, default 10000)
 *   CORVID_NODE_TOKEN_FILE        a file whose first line is the bearer token for nodes
 *   CORVID_NODE_TLS_CA            TLS to nodes, trusting this PEM CA file
 *   CORVID_NODE_TLS_CERT/_KEY     a client certificate for mutual TLS (both, and the CA) */
#ifndef CORVID_ENV_CLIENT_H
#define CORVID_ENV_CLIENT_H

#include "corvid/proxy.h"
#include "corvid/transfer.h"

/* What to read: a server (corvid-node) makes transfers but no proxy devices, and
 * its own CORVID_NODE_TOKEN_FILE is the token it demands, not one it presents. */
enum {
    CV_ENV_CLIENT_TRANSFER = 1, /* CORVID_TRANSFER_PATH */
    CV_ENV_CLIENT_PROXY = 2,    /* CORVID_NODE_* */
    CV_ENV_CLIENT_ALL = 3,
};

typedef struct cv_env_client {
    cv_transfer_path transfer_path; /* AUTO when unset */
    cv_proxy_options proxy;         /* strings point into the buffers below */
    char token[1040], tls_ca[1024], tls_cert[1024], tls_key[1024];
} cv_env_client;

/* Reads the variables of `parts` (the rest stays zero); a bad value is CV_ERROR_INVALID_ARGUMENT (or the token
 * file's error) naming the variable. */
cv_result cv_env_client_read(unsigned parts, cv_env_client *out);
/* Reads them and sets the library's settings of `parts` (cv_transfer_set_path,
 * cv_proxy_configure); on a bad variable nothing is set. */
cv_result cv_env_client_configure(unsigned parts);

#endif
