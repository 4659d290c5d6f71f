/* "host:port" lists (endpoint.h). */
#include "corvid/endpoint.h"

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static bool host_char(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '.' ||
           c == '_';
}

cv_result cv_endpoint_parse(const char *text, const char *what, cv_endpoint *out) {
    if (!text || !what || !out)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_endpoint_parse: NULL argument");
    size_t len = strlen(text);
    const char *colon = text[0] == '[' ? strstr(text, "]:") : strrchr(text, ':');
    if (colon && text[0] == '[')
        colon++; /* at the ':' after the bracket */
    if (!colon || colon == text)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: '%s' is not HOST:PORT", what, text);
    size_t host_len = (size_t)(colon - text);
    if (host_len > CV_ENDPOINT_HOST_MAX + 2)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: host of %zu characters in '%.40s...' (at most %u)", what,
                        host_len, text, CV_ENDPOINT_HOST_MAX);
    if (text[0] == '[') {
        for (size_t i = 1; i + 1 < host_len; i++)
            if (!strchr("0123456789abcdefABCDEF:.", text[i]))
                return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: '%s' has a bad IPv6 address", what, text);
        if (host_len < 3)
            return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: '%s' has an empty IPv6 address", what, text);
    } else {
        for (size_t i = 0; i < host_len; i++)
            if (!host_char(text[i]))
                return cv_error(CV_ERROR_INVALID_ARGUMENT,
                                "%s: '%s': the host may hold letters, digits, '-', '.' "
                                "and '_' (IPv6 goes in brackets: [::1]:7700)",
                                what, text);
    }
    const char *port = colon + 1;
    char *end;
    unsigned long p = port[0] >= '0' && port[0] <= '9' ? strtoul(port, &end, 10) : 0;
    if (port[0] < '0' || port[0] > '9' || *end || p == 0 || p > 65535 || (size_t)(end - text) != len)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: '%s': the port must be a number in 1..65535", what, text);
    cv_endpoint e;
    memcpy(e.host, text, host_len);
    e.host[host_len] = '\0';
    e.port = (uint16_t)p;
    snprintf(e.text, sizeof(e.text), "%s:%lu", e.host, p);
    *out = e;
    return CV_OK;
}

cv_result cv_endpoints_parse(const char *list, const char *what, cv_endpoint *out, uint32_t capacity,
                             uint32_t *count) {
    if (!list || !what || !out || !count)
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "cv_endpoints_parse: NULL argument");
    if (!list[0])
        return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: the list is empty", what);
    cv_endpoint *parsed = calloc(capacity ? capacity : 1, sizeof(*parsed));
    if (!parsed)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "%s", what);
    uint32_t n = 0;
    cv_result r = CV_OK;
    for (const char *p = list; r == CV_OK;) {
        const char *comma = strchr(p, ',');
        size_t len = comma ? (size_t)(comma - p) : strlen(p);
        char item[CV_ENDPOINT_HOST_MAX + 16];
        if (len == 0)
            r = cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: entry %u of '%s' is empty", what, n + 1, list);
        else if (len >= sizeof(item))
            r = cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: entry %u is %zu characters long", what, n + 1, len);
        else if (n == capacity)
            r = cv_error(CV_ERROR_LIMIT_EXCEEDED, "%s: more than %u nodes", what, capacity);
        if (r != CV_OK)
            break;
        snprintf(item, sizeof(item), "%.*s", (int)len, p);
        r = cv_endpoint_parse(item, what, &parsed[n]);
        for (uint32_t i = 0; r == CV_OK && i < n; i++)
            if (strcmp(parsed[i].text, parsed[n].text) == 0)
                r = cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: '%s' is listed twice", what, parsed[n].text);
        if (r != CV_OK)
            break;
        n++;
        if (!comma)
            break;
        p = comma + 1;
    }
    if (r == CV_OK) {
        memcpy(out, parsed, n * sizeof(*parsed));
        *count = n;
    }
    free(parsed);
    return r;
}
