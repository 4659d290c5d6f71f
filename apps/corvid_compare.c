/* corvid-compare: how far one render (B) is from another (A, the reference),
 * layer by layer, over the pixels both cover: RMSE, mean bias (B - A), largest
 * difference and SSIM (8x8 windows; image/include/corvid/image_metrics.h).
 * Reads the EXRs corvid-render writes (beauty R, G, B, A; albedo.RGB;
 * normal.XYZ; depth.Z; shadow.Y; ao.Y; direct.RGB; reflection.RGB and
 * motion.XY when the renderer made them). Exit 0 when compared, 2 for bad usage
 * or inputs that cannot be compared (missing or unreadable files, different
 * sizes, no layer in common). */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "corvid/image_exr.h"
#include "corvid/image_metrics.h"

static void usage(FILE *f) {
    fprintf(f,
            "usage: corvid-compare A.exr B.exr [--layer L] [--per-channel] [--json]\n"
            "Compares render B against reference A over the pixels both cover (finite depth.Z, else\n"
            "beauty alpha > 0, else every pixel), per layer both files have:\n"
            "  radiance  beauty R, G, B as luminance (0.2126 R + 0.7152 G + 0.0722 B)\n"
            "  albedo    albedo.R, G, B as luminance\n"
            "  normal    normal.X, Y, Z, each\n"
            "  depth     depth.Z\n"
            "  shadow    shadow.Y (sun visibility)\n"
            "  ao        ao.Y (ambient occlusion)\n"
            "  direct    direct.R, G, B (direct sun light) as luminance\n"
            "  reflection reflection.R, G, B as luminance\n"
            "  motion    motion.X, Y (screen-space motion, pixels), each\n"
            "and prints the pixels compared, RMSE, mean bias (B - A), largest |B - A| and SSIM\n"
            "(mean over fully covered 8x8 windows, C1 = (0.01 L)^2, C2 = (0.03 L)^2; L = 1 for\n"
            "shadow, ao and albedo, 2 for normals, A's largest |value| for the others).\n\n"
            "  --layer L       only layer L (one of the names above)\n"
            "  --per-channel   radiance and albedo per channel (R, G, B) as well as luminance\n"
            "  --json          one JSON object on stdout instead of the table\n"
            "Exit status: 0 compared, 2 bad usage or inputs that cannot be compared.\n");
}

typedef struct layer_def {
    const char *name;
    const char *channels[3]; /* full EXR channel names */
    uint32_t count;
    bool luminance; /* reduce to luminance (else each channel) */
    double peak;    /* SSIM's L; 0 = A's largest compared value */
} layer_def;

static const layer_def layer_defs[] = {
    { "radiance", { "R", "G", "B" }, 3, true, 0.0 },
    { "albedo", { "albedo.R", "albedo.G", "albedo.B" }, 3, true, 1.0 },
    { "normal", { "normal.X", "normal.Y", "normal.Z" }, 3, false, 2.0 },
    { "depth", { "depth.Z" }, 1, false, 0.0 },
    { "shadow", { "shadow.Y" }, 1, false, 1.0 },
    { "ao", { "ao.Y" }, 1, false, 1.0 },
    { "direct", { "direct.R", "direct.G", "direct.B" }, 3, true, 0.0 },
    { "reflection", { "reflection.R", "reflection.G", "reflection.B" }, 3, true, 0.0 },
    { "motion", { "motion.X", "motion.Y" }, 2, false, 0.0 },
};
#define LAYER_COUNT (sizeof layer_defs / sizeof layer_defs[0])

static bool has_layer(const cv_exr_image *img, const layer_def *d) {
    for (uint32_t c = 0; c < d->count; c++)
        if (!cv_exr_image_find(img, d->channels[c]))
            return false;
    return true;
}

/* Covered: finite positive depth if the file has depth, else alpha > 0 if it
 * has alpha, else every pixel. */
static void coverage(const cv_exr_image *img, uint8_t *covered) {
    size_t n = (size_t)img->width * img->height;
    const float *depth = cv_exr_image_find(img, "depth.Z"), *alpha = cv_exr_image_find(img, "A");
    for (size_t i = 0; i < n; i++)
        covered[i] = depth ? isfinite(depth[i]) && depth[i] > 0.0f : alpha ? alpha[i] > 0.0f : 1;
}

/* One row of output: a scalar plane of each file. */
typedef struct row {
    const char *layer;
    char channel[8];
    cv_image_metrics m;
    double peak;
} row;

static float *scalar_plane(const cv_exr_image *img, const layer_def *d, int channel) {
    size_t n = (size_t)img->width * img->height;
    float *p = malloc(n * sizeof(float));
    if (!p)
        return NULL;
    if (channel >= 0) {
        memcpy(p, cv_exr_image_find(img, d->channels[channel]), n * sizeof(float));
        return p;
    }
    const float *r = cv_exr_image_find(img, d->channels[0]), *g = cv_exr_image_find(img, d->channels[1]),
                *b = cv_exr_image_find(img, d->channels[2]);
    for (size_t i = 0; i < n; i++)
        p[i] = 0.2126f * r[i] + 0.7152f * g[i] + 0.0722f * b[i];
    return p;
}

static int compare_row(const cv_exr_image *a, const cv_exr_image *b, const uint8_t *mask, const layer_def *d,
                       int channel, row *out) {
    float *pa = scalar_plane(a, d, channel), *pb = scalar_plane(b, d, channel);
    int rc = 0;
    if (!pa || !pb) {
        fprintf(stderr, "corvid-compare: out of memory for layer '%s' (2 planes of %ux%u floats)\n", d->name,
                a->width, a->height);
        rc = 2;
    }
    size_t n = (size_t)a->width * a->height;
    double peak = d->peak;
    if (rc == 0 && peak <= 0.0) {
        for (size_t i = 0; i < n; i++)
            if (mask[i] && isfinite(pa[i]))
                peak = fmax(peak, fabs(pa[i]));
        if (!(peak > 0.0))
            peak = 1.0;
    }
    out->layer = d->name;
    snprintf(out->channel, sizeof out->channel, "%s",
             channel < 0                          ? "L"
             : strrchr(d->channels[channel], '.') ? strrchr(d->channels[channel], '.') + 1
                                                  : d->channels[channel]);
    out->peak = peak;
    if (rc == 0 && cv_image_metrics_f32(pa, pb, mask, a->width, a->height, peak, &out->m) != CV_OK) {
        fprintf(stderr, "corvid-compare: %s\n", cv_last_error());
        rc = 2;
    }
    free(pa);
    free(pb);
    return rc;
}

static void print_number(double v) {
    if (isnan(v))
        printf("null");
    else
        printf("%.9g", v);
}

static void print_json_string(const char *s) {
    putchar('"');
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            printf("\\%c", c);
        else if (c < 0x20)
            printf("\\u%04x", c);
        else
            putchar(c);
    }
    putchar('"');
}

/* What the command line asks for. */
typedef struct args {
    const char *paths[2];
    const layer_def *selected; /* --layer; NULL = every layer */
    bool json, per_channel;
} args;

/* -1 to compare, else the exit status (0 after --help, 2 after a message). */
static int parse_args(int argc, char **argv, args *o) {
    *o = (args){ 0 };
    const char *only = NULL;
    int npaths = 0;
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        if (!strcmp(arg, "--help") || !strcmp(arg, "-h")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(arg, "--json")) {
            o->json = true;
        } else if (!strcmp(arg, "--per-channel")) {
            o->per_channel = true;
        } else if (!strcmp(arg, "--layer") || !strncmp(arg, "--layer=", 8)) {
            only = arg[7] == '=' ? arg + 8 : (i + 1 < argc ? argv[++i] : NULL);
            if (!only || !*only) {
                fprintf(stderr, "corvid-compare: --layer needs a layer name\n");
                return 2;
            }
        } else if (arg[0] == '-' && arg[1] == '-') {
            fprintf(stderr, "corvid-compare: unknown option '%s' (see --help)\n", arg);
            return 2;
        } else if (npaths < 2) {
            o->paths[npaths++] = arg;
        } else {
            fprintf(stderr, "corvid-compare: more than two files ('%s'); see --help\n", arg);
            return 2;
        }
    }
    if (npaths != 2) {
        usage(stderr);
        return 2;
    }
    if (only) {
        for (size_t k = 0; k < LAYER_COUNT; k++)
            if (!strcmp(only, layer_defs[k].name))
                o->selected = &layer_defs[k];
        if (!o->selected) {
            fprintf(stderr,
                    "corvid-compare: unknown layer '%s' (radiance, albedo, normal, depth, shadow, ao, direct, "
                    "reflection, motion)\n",
                    only);
            return 2;
        }
    }
    return -1;
}

/* One comparison of two read files: coverage and the rows of metrics. */
typedef struct comparison {
    const char *paths[2];
    cv_exr_image img[2];
    uint64_t covered[2], both;
    row rows[LAYER_COUNT * 4];
    size_t nrows;
} comparison;

/* The layers both files have (the selected one only): 0, or 2 after a message. */
static int common_layers(const comparison *c, const layer_def *selected, const layer_def **common, size_t *ncommon) {
    int rc = 0;
    *ncommon = 0;
    for (size_t k = 0; rc == 0 && k < LAYER_COUNT; k++) {
        const layer_def *d = &layer_defs[k];
        if (selected && d != selected)
            continue;
        bool in_a = has_layer(&c->img[0], d), in_b = has_layer(&c->img[1], d);
        if (selected && (!in_a || !in_b)) {
            fprintf(stderr, "corvid-compare: layer '%s' is not in %s%s%s\n", d->name, !in_a ? c->paths[0] : "",
                    !in_a && !in_b ? " nor in " : "", !in_b ? c->paths[1] : "");
            rc = 2;
        }
        if (in_a && in_b)
            common[(*ncommon)++] = d;
    }
    if (rc == 0 && *ncommon == 0) {
        fprintf(stderr,
                "corvid-compare: %s and %s have no layer in common (radiance R/G/B, albedo.*, normal.*, "
                "depth.Z, shadow.Y, ao.Y, direct.*, reflection.*, motion.*)\n",
                c->paths[0], c->paths[1]);
        rc = 2;
    }
    return rc;
}

/* The rows of every common layer over the pixels both files cover: 0, or 2 after a message. */
static int compare_layers(comparison *c, const layer_def *const *common, size_t ncommon, bool per_channel) {
    size_t n = (size_t)c->img[0].width * c->img[0].height;
    uint8_t *cov[2] = { malloc(n), malloc(n) }, *mask = malloc(n);
    int rc = 0;
    if (!cov[0] || !cov[1] || !mask) {
        fprintf(stderr, "corvid-compare: out of memory for the coverage masks (%zu pixels)\n", n);
        rc = 2;
    }
    if (rc == 0) {
        coverage(&c->img[0], cov[0]);
        coverage(&c->img[1], cov[1]);
        for (size_t i = 0; i < n; i++) {
            c->covered[0] += cov[0][i];
            c->covered[1] += cov[1][i];
            mask[i] = cov[0][i] && cov[1][i];
            c->both += mask[i];
        }
    }
    for (size_t k = 0; rc == 0 && k < ncommon; k++) {
        const layer_def *d = common[k];
        if (d->luminance) {
            rc = compare_row(&c->img[0], &c->img[1], mask, d, -1, &c->rows[c->nrows++]);
            for (uint32_t ch = 0; rc == 0 && per_channel && ch < d->count; ch++)
                rc = compare_row(&c->img[0], &c->img[1], mask, d, (int)ch, &c->rows[c->nrows++]);
        } else {
            for (uint32_t ch = 0; rc == 0 && ch < d->count; ch++)
                rc = compare_row(&c->img[0], &c->img[1], mask, d, (int)ch, &c->rows[c->nrows++]);
        }
    }
    free(cov[0]);
    free(cov[1]);
    free(mask);
    return rc;
}

static void print_json(const comparison *c) {
    printf("{\"a\": ");
    print_json_string(c->paths[0]);
    printf(", \"b\": ");
    print_json_string(c->paths[1]);
    printf(
        ", \"width\": %u, \"height\": %u, \"covered_a\": %llu, \"covered_b\": %llu, \"compared\": %llu, "
        "\"layers\": [",
        c->img[0].width, c->img[0].height, (unsigned long long)c->covered[0], (unsigned long long)c->covered[1],
        (unsigned long long)c->both);
    for (size_t r = 0; r < c->nrows; r++) {
        const cv_image_metrics *m = &c->rows[r].m;
        printf("%s\n  {\"layer\": \"%s\", \"channel\": \"%s\", \"pixels\": %llu, \"nonfinite\": %llu, \"rmse\": ",
               r ? "," : "", c->rows[r].layer, c->rows[r].channel, (unsigned long long)m->pixels,
               (unsigned long long)m->nonfinite);
        print_number(m->rmse);
        printf(", \"bias\": ");
        print_number(m->bias);
        printf(", \"max_abs\": ");
        print_number(m->max_abs);
        printf(", \"ssim\": ");
        print_number(m->ssim);
        printf(", \"ssim_windows\": %llu, \"ssim_peak\": ", (unsigned long long)m->ssim_windows);
        print_number(c->rows[r].peak);
        printf("}");
    }
    printf("\n]}\n");
}

static void print_table(const comparison *c) {
    printf("A: %s\nB: %s\n%ux%u: %llu pixels covered in A, %llu in B, %llu in both (compared)\n", c->paths[0],
           c->paths[1], c->img[0].width, c->img[0].height, (unsigned long long)c->covered[0],
           (unsigned long long)c->covered[1], (unsigned long long)c->both);
    printf("%-10s %-3s %9s %11s %11s %11s %9s %8s\n", "layer", "ch", "pixels", "rmse", "bias(B-A)", "max|B-A|",
           "ssim", "windows");
    for (size_t r = 0; r < c->nrows; r++) {
        const cv_image_metrics *m = &c->rows[r].m;
        printf("%-10s %-3s %9llu %11.6f %+11.6f %11.6f ", c->rows[r].layer, c->rows[r].channel,
               (unsigned long long)m->pixels, m->rmse, m->bias, m->max_abs);
        if (isnan(m->ssim))
            printf("%9s", "n/a");
        else
            printf("%9.5f", m->ssim);
        printf(" %8llu", (unsigned long long)m->ssim_windows);
        if (m->nonfinite)
            printf("  (%llu non-finite pixels left out)", (unsigned long long)m->nonfinite);
        printf("\n");
    }
}

int main(int argc, char **argv) {
    args o;
    int parsed = parse_args(argc, argv, &o);
    if (parsed >= 0)
        return parsed;
    comparison c = { .paths = { o.paths[0], o.paths[1] } };
    cv_result read;
    for (int f = 0; f < 2; f++)
        if ((read = cv_exr_read(c.paths[f], &c.img[f])) != CV_OK) {
            /* the result's name too: "a.exr: out of memory for channel 'R' ..." is not a channel's name */
            fprintf(stderr, "corvid-compare: %s: %s\n", cv_result_name(read), cv_last_error());
            cv_exr_image_free(&c.img[0]);
            return 2;
        }
    int rc = 0;
    if (c.img[0].width != c.img[1].width || c.img[0].height != c.img[1].height) {
        fprintf(stderr, "corvid-compare: %s is %ux%u but %s is %ux%u; compare renders of the same size\n", c.paths[0],
                c.img[0].width, c.img[0].height, c.paths[1], c.img[1].width, c.img[1].height);
        rc = 2;
    }
    const layer_def *common[LAYER_COUNT];
    size_t ncommon = 0;
    if (rc == 0)
        rc = common_layers(&c, o.selected, common, &ncommon);
    if (rc == 0)
        rc = compare_layers(&c, common, ncommon, o.per_channel);
    if (rc == 0 && o.json)
        print_json(&c);
    else if (rc == 0)
        print_table(&c);
    cv_exr_image_free(&c.img[0]);
    cv_exr_image_free(&c.img[1]);
    return rc;
}
