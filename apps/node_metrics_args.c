/* corvid-node's --metrics-port, --metrics-listen and --metrics-token-file (node_metrics_args.h). */
#include "node_metrics_args.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* argv[i] is `name` ("--x v" or "--x=v"): *value is the value (NULL if missing), *used the words taken. */
static bool match(int argc, char **argv, int i, const char *name, const char **value, int *used) {
    size_t len = strlen(name);
    if (strncmp(argv[i], name, len) != 0)
        return false;
    if (argv[i][len] == '=') {
        *value = argv[i] + len + 1;
        *used = 1;
        return true;
    }
    if (argv[i][len] != '\0')
        return false;
    *value = i + 1 < argc ? argv[i + 1] : NULL;
    *used = *value ? 2 : 1;
    return true;
}

int node_metrics_args(int *argc, char **argv, node_metrics_options *out) {
    node_metrics_options o = { 0 };
    int kept = 0;
    for (int i = 0; i < *argc;) {
        const char *value = NULL;
        int used = 0;
        const char *name = NULL;
        if (match(*argc, argv, i, "--metrics-port", &value, &used))
            name = "--metrics-port";
        else if (match(*argc, argv, i, "--metrics-listen", &value, &used))
            name = "--metrics-listen";
        else if (match(*argc, argv, i, "--metrics-token-file", &value, &used))
            name = "--metrics-token-file";
        if (!name) {
            argv[kept++] = argv[i++];
            continue;
        }
        if (!value) {
            fprintf(stderr, "corvid-node: %s needs a value (see --help)\n", name);
            return 2;
        }
        if (!strcmp(name, "--metrics-port")) {
            char *end = NULL;
            errno = 0;
            long v = *value && *value != '-' ? strtol(value, &end, 10) : -1;
            if (v < 0 || v > 65535 || errno || !end || *end) {
                fprintf(stderr, "corvid-node: --metrics-port: '%s' is not a port in 0..65535 (0 picks a free one)\n",
                        value);
                return 2;
            }
            o.enabled = true;
            o.port = (int)v;
        } else if (!strcmp(name, "--metrics-token-file")) {
            o.token_file = value;
        } else {
            if (!*value) {
                fprintf(stderr, "corvid-node: --metrics-listen: empty address\n");
                return 2;
            }
            o.listen = value;
        }
        i += used;
    }
    if ((o.listen || o.token_file) && !o.enabled) {
        fprintf(stderr, "corvid-node: %s needs --metrics-port\n",
                o.listen ? "--metrics-listen" : "--metrics-token-file");
        return 2;
    }
    for (int i = kept; i < *argc; i++)
        argv[i] = NULL;
    *argc = kept;
    *out = o;
    return 0;
}
