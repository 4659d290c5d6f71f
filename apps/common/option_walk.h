/* Walks a program's command line: its own options (found and set through the
 * program's callbacks) and the renderer's settings options
 * (corvid/render_options.h), "--name value" or "--name=value". One walker for
 * corvid-render and corvid-view, so both say the same things about a bad
 * command line:
 *
 *     option_walk w = { "corvid-view", find_view_option, set_view_option, &options, &options.settings };
 *     if (option_walk_run(&w, argc, argv) != 0)
 *         return 2;   // said on stderr: "corvid-view: unknown option '--x' (see --help)"
 */
#ifndef CORVID_APPS_OPTION_WALK_H
#define CORVID_APPS_OPTION_WALK_H

#include <stdbool.h>
#include <stddef.h>

#include "corvid/render_settings.h"

typedef struct option_walk {
    const char *program; /* the messages' prefix */
    /* The program's option named name[0..len), or NULL; *canonical: its name, *takes_value: whether
     * it takes a value (else a flag). */
    const void *(*find)(const char *name, size_t len, const char **canonical, bool *takes_value);
    /* Sets it from value (NULL for a flag): false when refused (said on stderr). */
    bool (*set)(void *options, const void *option, const char *value);
    void *options;
    cv_render_settings *settings; /* where the renderer's options go */
} option_walk;

/* 0, or 2 when an argument is refused (said on stderr, naming it). */
int option_walk_run(const option_walk *w, int argc, char **argv);

#endif
