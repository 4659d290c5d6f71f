/* corvid-node's metrics options, parsed apart from the rest of its command line
 * so they live in a file of their own:
 *   --metrics-port PORT     serve Prometheus metrics at http://ADDR:PORT/metrics (0 picks a free port)
 *   --metrics-listen ADDR   the address for it [127.0.0.1]
 *   --metrics-token-file FILE  scrapes must send "Authorization: Bearer <token>", the file's first line
 * Without --metrics-port there is no metrics endpoint. */
#ifndef CORVID_APPS_NODE_METRICS_ARGS_H
#define CORVID_APPS_NODE_METRICS_ARGS_H

#include <stdbool.h>

typedef struct node_metrics_options {
    bool enabled; /* --metrics-port given */
    int port;
    const char *listen;     /* NULL = 127.0.0.1 */
    const char *token_file; /* NULL = no token */
} node_metrics_options;

/* Takes the options above out of argv (argc shrinks); the rest is left in
 * order for the main parser. Returns 0, or 2 after printing why an option is bad. */
int node_metrics_args(int *argc, char **argv, node_metrics_options *out);

#endif
