/* The command-line walker of option_walk.h. */
#include "option_walk.h"

#include <stdio.h>
#include <string.h>

#include "corvid/render_options.h"

/* One option and its value (NULL for a flag): 0 = ok, 2 = refused (said on stderr). */
static int apply(const option_walk *w, const void *own, const cv_render_setting *setting, const char *value) {
    if (own)
        return w->set(w->options, own, value) ? 0 : 2;
    if (cv_render_option_apply(setting, value, w->settings) == CV_OK)
        return 0;
    fprintf(stderr, "%s: %s (see --help)\n", w->program, cv_last_error());
    return 2;
}

int option_walk_run(const option_walk *w, int argc, char **argv) {
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i], *eq = strchr(arg, '='), *name = NULL;
        size_t len = eq ? (size_t)(eq - arg) : strlen(arg);
        bool takes_value = true;
        const void *own = w->find(arg, len, &name, &takes_value);
        const cv_render_setting *setting = own ? NULL : cv_render_option_find(arg, len);
        if (!own && !setting) {
            fprintf(stderr, "%s: unknown option '%.*s' (see --help)\n", w->program, (int)len, arg);
            return 2;
        }
        if (!own)
            name = setting->option;
        const char *value = eq ? eq + 1 : NULL;
        if (takes_value && !value) {
            if (i + 1 == argc) {
                fprintf(stderr, "%s: %s needs a value (see --help)\n", w->program, name);
                return 2;
            }
            value = argv[++i];
        } else if (!takes_value && value) {
            fprintf(stderr, "%s: %s takes no value (see --help)\n", w->program, name);
            return 2;
        }
        if (apply(w, own, setting, value))
            return 2;
    }
    return 0;
}
