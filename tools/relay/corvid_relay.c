/* corvid-relay: a TCP relay that behaves like a network link (one-way delay and a bandwidth
 * cap per direction; tcp_relay.h has the model), for trying Corvid's remote paths by hand
 * and for benchmarks: put it between a viewer or a client and a corvid-node. Runs until
 * SIGINT or SIGTERM, then prints what it carried. */
#include <pthread.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "corvid/endpoint.h"
#include "corvid/parse.h"
#include "tcp_relay.h"

static const char usage[] =
    "usage: corvid-relay --listen HOST:PORT --target HOST:PORT [--delay-ms N] [--rate-mbit N]\n"
    "\n"
    "Accepts TCP connections on --listen and forwards each to --target, as a link with\n"
    "  --delay-ms N    one-way delay in each direction, 0..60000 ms (a round trip gains 2N; default 0)\n"
    "  --rate-mbit N   bandwidth cap in each direction, 1..100000 Mbit/s (default: none)\n"
    "A chunk leaves after its bytes have crossed the capped link and then the delay; each direction\n"
    "buffers what the link carries in the delay plus 50 ms, then pushes back on the sender.\n"
    "HOST: a name, an IPv4 address or a bracketed IPv6 address ([::1]). Ctrl-C stops it.\n";

typedef struct relay_options {
    cv_endpoint listen, target;
    char listen_host[CV_ENDPOINT_HOST_MAX + 3], target_host[CV_ENDPOINT_HOST_MAX + 3];
    uint64_t delay_ms, rate_mbit;
} relay_options;

/* "[::1]" -> "::1" for the resolver; other hosts as written. */
static void bare_host(const char *host, char *out, size_t size) {
    size_t n = strlen(host);
    if (n >= 2 && host[0] == '[' && host[n - 1] == ']')
        snprintf(out, size, "%.*s", (int)(n - 2), host + 1);
    else
        snprintf(out, size, "%s", host);
}

/* 0: run; 1: an error (printed); 2: --help (printed). */
static int parse_args(int argc, char **argv, relay_options *o) {
    bool have_listen = false, have_target = false;
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        if (!strcmp(arg, "--help") || !strcmp(arg, "-h")) {
            fputs(usage, stdout);
            return 2;
        }
        bool known = !strcmp(arg, "--listen") || !strcmp(arg, "--target") || !strcmp(arg, "--delay-ms") ||
                     !strcmp(arg, "--rate-mbit");
        if (!known) {
            fprintf(stderr, "corvid-relay: unknown option '%s' (--help lists them)\n", arg);
            return 1;
        }
        if (i + 1 >= argc) {
            fprintf(stderr, "corvid-relay: %s needs a value\n", arg);
            return 1;
        }
        const char *value = argv[++i];
        cv_result r = CV_OK;
        if (!strcmp(arg, "--listen") && (r = cv_endpoint_parse(value, "--listen", &o->listen)) == CV_OK)
            have_listen = true;
        else if (!strcmp(arg, "--target") && (r = cv_endpoint_parse(value, "--target", &o->target)) == CV_OK)
            have_target = true;
        else if (!strcmp(arg, "--delay-ms"))
            r = cv_parse_uint_named("--delay-ms", value, 0, 60000, &o->delay_ms);
        else if (!strcmp(arg, "--rate-mbit"))
            r = cv_parse_uint_named("--rate-mbit", value, 1, 100000, &o->rate_mbit);
        if (r != CV_OK) {
            fprintf(stderr, "corvid-relay: %s\n", cv_last_error());
            return 1;
        }
    }
    if (!have_listen || !have_target) {
        fprintf(stderr, "corvid-relay: %s is required\n%s", have_listen ? "--target" : "--listen", usage);
        return 1;
    }
    bare_host(o->listen.host, o->listen_host, sizeof o->listen_host);
    bare_host(o->target.host, o->target_host, sizeof o->target_host);
    return 0;
}

int main(int argc, char **argv) {
    relay_options o = { 0 };
    int parsed = parse_args(argc, argv, &o);
    if (parsed)
        return parsed == 2 ? 0 : 2;
    /* The relay's thread inherits the mask: the signals come to sigwait below. A shell starts a
     * background program with SIGINT ignored, and an ignored signal is dropped, not waited for:
     * the default action is restored first (blocked, it does not end the program). */
    sigset_t stop;
    sigemptyset(&stop);
    sigaddset(&stop, SIGINT);
    sigaddset(&stop, SIGTERM);
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    pthread_sigmask(SIG_BLOCK, &stop, NULL);
    tcp_relay_desc desc = { .listen_host = o.listen_host,
                            .listen_port = o.listen.port,
                            .target_host = o.target_host,
                            .target_port = o.target.port,
                            .delay_us = (uint32_t)(o.delay_ms * 1000u),
                            .rate_bytes_per_s = o.rate_mbit * 1000000u / 8u };
    tcp_relay *relay = NULL;
    if (tcp_relay_create(&desc, &relay) != CV_OK) {
        fprintf(stderr, "corvid-relay: %s\n", cv_last_error());
        return 1;
    }
    char rate[32] = "no bandwidth cap";
    if (o.rate_mbit)
        snprintf(rate, sizeof rate, "%llu Mbit/s", (unsigned long long)o.rate_mbit);
    printf("corvid-relay: %s -> %s, +%llu ms each way, %s\n", o.listen.text, o.target.text,
           (unsigned long long)o.delay_ms, rate);
    fflush(stdout);
    int sig = 0;
    sigwait(&stop, &sig);
    tcp_relay_stats s = tcp_relay_get_stats(relay);
    tcp_relay_stop(relay);
    printf("corvid-relay: stopped (%s): %llu connections, %.3f MB to the target, %.3f MB back\n", strsignal(sig),
           (unsigned long long)s.connections, (double)s.bytes_to_target / 1e6, (double)s.bytes_to_client / 1e6);
    return 0;
}
