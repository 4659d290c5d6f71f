/* The process's proxy options (proxy.h, cv_proxy_configure; proxy_options.c)
 * as each device and node query takes them.
 *
 *     proxy_settings s;
 *     proxy_settings_get(&s);
 *     cv_rpc_client_config cc;
 *     proxy_client_config(&s, &cc);
 *     cv_rpc_client_create(endpoint, &cc, &client);
 *     memset(s.token, 0, sizeof(s.token)); */
#ifndef CORVID_PROXY_OPTIONS_H
#define CORVID_PROXY_OPTIONS_H

#include "corvid/proxy.h"
#include "corvid/rpc.h"

/* A copy of the options, its strings in its own buffers, timeout_ms filled in with the default. Wipe `token`
 * after use. */
typedef struct proxy_settings {
    cv_proxy_options options;
    char token[1040], tls_ca[1024], tls_cert[1024], tls_key[1024];
} proxy_settings;
void proxy_settings_get(proxy_settings *out);
/* The rpc client configuration for talking to a node: the bearer token, TLS (trusting tls_ca_file, with a
 * client certificate for mutual TLS), keepalive ping interval and timeout (so a node that stops answering is
 * noticed within about twice keepalive_ms; 0: the rpc defaults, 10 s + 5 s). Points into `s`. */
void proxy_client_config(const proxy_settings *s, cv_rpc_client_config *cc);

#endif
