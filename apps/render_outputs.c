/* See render_outputs.h. */
#include "render_outputs.h"

#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* A copy of `a` followed by `b`, or NULL without memory. */
static char *concat(const char *a, const char *b) {
    size_t na = strlen(a), nb = strlen(b);
    char *s = malloc(na + nb + 1);
    if (s) {
        memcpy(s, a, na);
        memcpy(s + na, b, nb + 1);
    }
    return s;
}

/* Creates the missing folders of PREFIX (like mkdir -p), remembering the
 * ones it made. */
static cv_result make_parent(const char *prefix, outputs *out) {
    char *dir = strdup(prefix);
    if (!dir)
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "--out: no memory");
    char *slash = strrchr(dir, '/');
    if (!slash || slash == dir) {
        free(dir);
        return CV_OK;
    }
    *slash = '\0';
    size_t len = strlen(dir);
    for (char *p = dir + 1; p <= dir + len; p++) {
        if (*p != '/' && *p != '\0')
            continue;
        char c = *p;
        *p = '\0';
        if (mkdir(dir, 0777) == 0) {
            if (!out->made)
                out->made_top = strlen(dir);
            out->made = dir;
        } else if (errno != EEXIST) {
            cv_result r = cv_error(CV_ERROR_IO, "cannot create folder '%s': %s", dir, strerror(errno));
            *p = c;
            if (out->made != dir)
                free(dir);
            return r;
        }
        *p = c;
    }
    if (out->made != dir)
        free(dir);
    return CV_OK;
}

void outputs_discard(outputs *out) {
    cv_file_set_destroy(out->set);
    out->set = NULL;
    for (char *dir = out->made; dir && strlen(dir) >= out->made_top;) {
        rmdir(dir);
        char *slash = strrchr(dir, '/');
        if (!slash)
            break;
        *slash = '\0';
    }
}

void outputs_free(outputs *out) {
    cv_file_set_destroy(out->set);
    free(out->made);
    free(out->exr);
    free(out->png);
    free(out->dot);
}

/* Whether paths a and b name the same file: the same file name in the same
 * folder, however the folder is written ("out/x.json", "./out/x.json"). */
static bool same_destination(const char *a, const char *b) {
    const char *sa = strrchr(a, '/'), *sb = strrchr(b, '/');
    if (strcmp(sa ? sa + 1 : a, sb ? sb + 1 : b) != 0)
        return false;
    char *da = sa ? strndup(a, sa == a ? 1 : (size_t)(sa - a)) : strdup(".");
    char *db = sb ? strndup(b, sb == b ? 1 : (size_t)(sb - b)) : strdup(".");
    char *ra = da ? realpath(da, NULL) : NULL, *rb = db ? realpath(db, NULL) : NULL;
    bool same = ra && rb ? strcmp(ra, rb) == 0 : da && db && strcmp(da, db) == 0;
    free(da), free(db), free(ra), free(rb);
    return same;
}

/* One file of the set: its option, what a clash calls it, where its temporary goes. */
typedef struct output_file {
    const char *option, *path, *called;
    const char **temp;
} output_file;

cv_result outputs_reserve(outputs *out, const char *prefix, const char *stats, const char *trace, const char *graph) {
    out->exr = concat(prefix, ".exr");
    out->png = concat(prefix, ".png");
    out->dot = graph ? concat(graph, ".dot") : NULL;
    if (!out->exr || !out->png || (graph && !out->dot))
        return cv_error(CV_ERROR_OUT_OF_MEMORY, "--out: no memory");
    const output_file files[] = {
        { "--out", out->exr, "the EXR", &out->exr_temp },
        { "--out", out->png, "the PNG", &out->png_temp },
        { "--stats", stats, "the --stats file", &out->stats_temp },
        { "--trace", trace, "the --trace file", &out->trace_temp },
        { "--dump-graph", graph, "the --dump-graph file", &out->graph_temp },
        { "--dump-graph", out->dot, "the --dump-graph dot file", &out->dot_temp },
    };
    const size_t count = sizeof files / sizeof files[0];
    for (size_t i = 2; i < count; i++)
        for (size_t j = 0; files[i].path && j < i; j++)
            if (files[j].path && same_destination(files[i].path, files[j].path))
                return cv_error(CV_ERROR_INVALID_ARGUMENT, "%s: '%s' is also %s", files[i].option, files[i].path,
                                files[j].called);
    cv_result r = make_parent(prefix, out);
    if (r == CV_OK)
        r = cv_file_set_create(&out->set);
    for (size_t i = 0; i < count && r == CV_OK; i++)
        if (files[i].path && (r = cv_file_set_add(out->set, files[i].path, files[i].temp)) != CV_OK)
            r = cv_error(r, "%s: %s", files[i].option, cv_last_error());
    return r;
}

/* What the signal handler removes besides the temporaries: the folders --out
 * created, deepest first. Process-wide because a signal handler can reach
 * nothing else; set before the handler is installed, freed after it is gone. */
static char **signal_dirs;
static size_t signal_dir_count;

static void on_signal(int sig) {
    cv_image_temps_remove_all();
    for (size_t i = 0; i < signal_dir_count; i++)
        rmdir(signal_dirs[i]);
    static const char msg[] = "corvid-render: interrupted: removed the unfinished output files\n";
    ssize_t ignored = write(STDERR_FILENO, msg, sizeof msg - 1);
    (void)ignored;
    _exit(128 + sig);
}

void outputs_catch_signals(const outputs *out) {
    size_t n = 0;
    for (const char *p = out->made; p && *p; p++)
        n += *p == '/';
    signal_dirs = calloc(n + 1, sizeof(*signal_dirs));
    signal_dir_count = 0;
    if (signal_dirs && out->made) {
        char *dir = strdup(out->made);
        while (dir && strlen(dir) >= out->made_top) {
            signal_dirs[signal_dir_count++] = dir;
            char *slash = strrchr(dir, '/');
            dir = slash ? strndup(dir, (size_t)(slash - dir)) : NULL;
        }
        free(dir);
    }
    struct sigaction sa = { .sa_handler = on_signal };
    sigemptyset(&sa.sa_mask);
    sigaddset(&sa.sa_mask, SIGINT); /* one cleanup, not a second one inside the first */
    sigaddset(&sa.sa_mask, SIGTERM);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

void outputs_release_signals(void) {
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    for (size_t i = 0; i < signal_dir_count; i++)
        free(signal_dirs[i]);
    free(signal_dirs);
    signal_dirs = NULL;
    signal_dir_count = 0;
}
