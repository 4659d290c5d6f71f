/* corvid-compare as a user runs it, on EXRs written here with corvid-render's
 * layer names: a file against itself gives RMSE 0 and SSIM 1 on every layer;
 * a known offset of the shadow layer gives that bias; Gaussian noise of known
 * sigma on AO gives that RMSE within sampling error; only covered pixels
 * (finite depth) count; bad inputs (missing file, different sizes, no common
 * layer, unknown or absent --layer, a FIFO, out of memory) exit 2 with a message
 * naming the problem.
 * argv[1]: the corvid-compare executable. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include "check.h"
#include "corvid/image_exr.h"
#include "scratch_dir.h"

enum { W = 64, H = 48, UNCOVERED = 8 }; /* the left UNCOVERED columns are sky (depth +inf) */

static const char *tool;

static uint32_t rng = 777u;
static double uniform(void) {
    rng ^= rng << 13;
    rng ^= rng >> 17;
    rng ^= rng << 5;
    return (rng + 0.5) / 4294967296.0;
}
static double gaussian(void) { return sqrt(-2.0 * log(uniform())) * cos(6.283185307179586 * uniform()); }

/* A render-like EXR; shadow + shadow_offset, AO + noise_sigma * N(0, 1);
 * direct = 2 * shadow (grey), motion = (10 * shadow_offset + x / 8, -1). */
static void write_frame(const char *path, uint32_t w, uint32_t h, float shadow_offset, double noise_sigma,
                        int with_ao) {
    size_t n = (size_t)w * h;
    float *rgba = malloc(n * 4 * sizeof(float)), *depth = malloc(n * 4), *shadow = malloc(n * 4), *ao = malloc(n * 4),
          *nx = malloc(n * 4), *ny = malloc(n * 4), *nz = malloc(n * 4), *direct = malloc(n * 4), *mx = malloc(n * 4),
          *my = malloc(n * 4);
    for (size_t i = 0; i < n; i++) {
        uint32_t x = i % w, y = i / w;
        int covered = x >= UNCOVERED;
        shadow[i] = (x / 5 + y / 5) % 3 == 0 ? 0.1f : 0.9f;
        shadow[i] += shadow_offset;
        ao[i] = 0.6f + 0.3f * sinf(x * 0.2f) * cosf(y * 0.3f) + (float)(noise_sigma * gaussian());
        depth[i] = covered ? 2.0f + x * 0.01f : INFINITY;
        nx[i] = 0.0f;
        ny[i] = 1.0f;
        nz[i] = 0.0f;
        direct[i] = 2.0f * shadow[i];
        mx[i] = 10.0f * shadow_offset + x / 8.0f;
        my[i] = -1.0f;
        for (int c = 0; c < 3; c++)
            rgba[i * 4 + c] = covered ? shadow[i] * (0.5f + 0.1f * c) : 0.2f;
        rgba[i * 4 + 3] = covered ? 1.0f : 0.0f;
    }
    cv_exr_layer layers[] = {
        { .channel_count = 4, .channels = { "R", "G", "B", "A" }, .type = CV_EXR_FLOAT, .interleaved = rgba },
        { .name = "normal",
          .channel_count = 3,
          .channels = { "X", "Y", "Z" },
          .type = CV_EXR_FLOAT,
          .planes = { nx, ny, nz } },
        { .name = "depth", .channel_count = 1, .channels = { "Z" }, .type = CV_EXR_FLOAT, .planes = { depth } },
        { .name = "shadow", .channel_count = 1, .channels = { "Y" }, .type = CV_EXR_FLOAT, .planes = { shadow } },
        { .name = "direct",
          .channel_count = 3,
          .channels = { "R", "G", "B" },
          .type = CV_EXR_FLOAT,
          .planes = { direct, direct, direct } },
        { .name = "motion",
          .channel_count = 2,
          .channels = { "X", "Y" },
          .type = CV_EXR_FLOAT,
          .planes = { mx, my } },
        { .name = "ao", .channel_count = 1, .channels = { "Y" }, .type = CV_EXR_FLOAT, .planes = { ao } },
    };
    CHECK_OK(cv_exr_write(path, &(cv_exr_desc){ .width = w,
                                                .height = h,
                                                .compression = CV_EXR_ZIP,
                                                .layer_count = with_ao ? 7 : 6,
                                                .layers = layers }));
    free(rgba), free(depth), free(shadow), free(ao), free(nx), free(ny), free(nz), free(direct), free(mx), free(my);
}

/* Runs corvid-compare with `args` (under `limit`, shell commands before it;
 * at most 30 s: a hang fails the check, not the whole test); its stdout and
 * stderr in static buffers. */
static char out_text[65536], err_text[8192];
static const char *limit = "";
static int run(const char *args) {
    char cmd[4096];
    const char *err_path = scratch_path(3, "stderr.txt");
    snprintf(cmd, sizeof cmd, "%s timeout 30 '%s' %s 2> '%s'", limit, tool, args, err_path);
    FILE *p = popen(cmd, "r");
    size_t got = p ? fread(out_text, 1, sizeof out_text - 1, p) : 0;
    out_text[got] = 0;
    int status = p ? pclose(p) : -1;
    FILE *e = fopen(err_path, "r");
    got = e ? fread(err_text, 1, sizeof err_text - 1, e) : 0;
    err_text[got] = 0;
    if (e)
        fclose(e);
    return status >= 0 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/* A number field of the JSON row for `layer`/`channel`; NAN if absent. */
static double field(const char *layer, const char *channel, const char *name) {
    char key[96];
    snprintf(key, sizeof key, "\"layer\": \"%s\", \"channel\": \"%s\"", layer, channel);
    const char *row = strstr(out_text, key);
    if (!row)
        return NAN;
    char fkey[64];
    snprintf(fkey, sizeof fkey, "\"%s\": ", name);
    const char *f = strstr(row, fkey), *end = strchr(row, '}');
    if (!f || (end && f > end))
        return NAN;
    f += strlen(fkey);
    return strncmp(f, "null", 4) == 0 ? NAN : strtod(f, NULL);
}

static double top_field(const char *name) {
    char fkey[64];
    snprintf(fkey, sizeof fkey, "\"%s\": ", name);
    const char *f = strstr(out_text, fkey);
    return f ? strtod(f + strlen(fkey), NULL) : NAN;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: compare_cli_test CORVID_COMPARE\n");
        return 2;
    }
    tool = argv[1];
    scratch_dir_create("compare");
    char a[1024], b[1024], c[1024], d[1024], e[1024], args[4096];
    snprintf(a, sizeof a, "%s", scratch_path(0, "a.exr"));
    snprintf(b, sizeof b, "%s", scratch_path(0, "offset.exr"));
    snprintf(c, sizeof c, "%s", scratch_path(0, "noise.exr"));
    snprintf(d, sizeof d, "%s", scratch_path(0, "small.exr"));
    snprintf(e, sizeof e, "%s", scratch_path(0, "noao.exr"));
    write_frame(a, W, H, 0.0f, 0.0, 1);
    write_frame(b, W, H, 0.05f, 0.0, 1);
    rng = 777u; /* the same sequence as a.exr's (unused there), then noise */
    write_frame(c, W, H, 0.0f, 0.1, 1);
    write_frame(d, W / 2, H, 0.0f, 0.0, 1);
    write_frame(e, W, H, 0.0f, 0.0, 0);
    const uint32_t covered = (W - UNCOVERED) * H;

    /* Identical: every layer RMSE 0, bias 0, SSIM 1; pixel counts. */
    snprintf(args, sizeof args, "'%s' '%s' --json", a, a);
    CHECK_EQ_INT(run(args), 0);
    CHECK_EQ_INT((int)top_field("compared"), covered);
    CHECK_EQ_INT((int)top_field("covered_a"), covered);
    const char *rows[][2] = { { "radiance", "L" }, { "normal", "X" }, { "normal", "Y" }, { "normal", "Z" },
                              { "depth", "Z" },    { "shadow", "Y" }, { "ao", "Y" },     { "direct", "L" },
                              { "motion", "X" },   { "motion", "Y" } };
    for (int r = 0; r < 10; r++) {
        CHECK(field(rows[r][0], rows[r][1], "rmse") == 0.0);
        CHECK(field(rows[r][0], rows[r][1], "bias") == 0.0);
        CHECK(field(rows[r][0], rows[r][1], "ssim") == 1.0);
        CHECK_EQ_INT((int)field(rows[r][0], rows[r][1], "pixels"), covered);
    }
    CHECK(!strstr(out_text, "\"albedo\"")); /* not in the files */

    /* Shadow + 0.05: bias 0.05 = RMSE; AO untouched. The table form says the same. */
    snprintf(args, sizeof args, "'%s' '%s' --json", a, b);
    CHECK_EQ_INT(run(args), 0);
    CHECK(fabs(field("shadow", "Y", "bias") - 0.05) < 1e-6);
    CHECK(fabs(field("shadow", "Y", "rmse") - 0.05) < 1e-6);
    CHECK(field("ao", "Y", "rmse") == 0.0);
    /* The per-pass layers: direct = 2 * shadow (luminance weights sum to 1), motion.X + 0.5. */
    CHECK(fabs(field("direct", "L", "bias") - 0.1) < 1e-5);
    CHECK(fabs(field("motion", "X", "bias") - 0.5) < 1e-6);
    CHECK(field("motion", "Y", "rmse") == 0.0);
    CHECK(!strstr(out_text, "\"reflection\"")); /* not in the files */
    snprintf(args, sizeof args, "'%s' '%s' --layer shadow", a, b);
    CHECK_EQ_INT(run(args), 0);
    CHECK(strstr(out_text, "+0.050000") != NULL);
    CHECK(strstr(out_text, "ao ") == NULL);
    fputs(out_text, stderr);

    /* AO + N(0, 0.1): RMSE 0.1 within 5% (2688 samples: spread ~1.4%). */
    snprintf(args, sizeof args, "'%s' '%s' --json --layer=ao", a, c);
    CHECK_EQ_INT(run(args), 0);
    double rmse = field("ao", "Y", "rmse");
    fprintf(stderr, "noise sigma 0.1: RMSE %.5f, SSIM %.4f\n", rmse, field("ao", "Y", "ssim"));
    CHECK(fabs(rmse - 0.1) < 0.005);
    CHECK(field("ao", "Y", "ssim") < 0.9);
    CHECK(isnan(field("shadow", "Y", "rmse"))); /* only the layer asked for */

    /* Only layers in both: a file without AO compares the rest. */
    snprintf(args, sizeof args, "'%s' '%s' --json", a, e);
    CHECK_EQ_INT(run(args), 0);
    CHECK(isnan(field("ao", "Y", "rmse")) && field("shadow", "Y", "rmse") == 0.0);

    /* Refused, exit 2, with the reason. */
    snprintf(args, sizeof args, "'%s' '%s/missing.exr'", a, scratch_path(1, ""));
    CHECK_EQ_INT(run(args), 2);
    CHECK(strstr(err_text, "missing.exr") != NULL);
    snprintf(args, sizeof args, "'%s' '%s'", a, d);
    CHECK_EQ_INT(run(args), 2);
    CHECK(strstr(err_text, "64x48") && strstr(err_text, "32x48"));
    snprintf(args, sizeof args, "'%s' '%s' --layer ao", a, e);
    CHECK_EQ_INT(run(args), 2);
    CHECK(strstr(err_text, "layer 'ao' is not in") && strstr(err_text, "noao.exr"));
    snprintf(args, sizeof args, "'%s' '%s' --layer specular", a, a);
    CHECK_EQ_INT(run(args), 2);
    CHECK(strstr(err_text, "unknown layer 'specular'") != NULL);
    snprintf(args, sizeof args, "'%s'", a);
    CHECK_EQ_INT(run(args), 2);
    CHECK(strstr(err_text, "usage") != NULL);
    snprintf(args, sizeof args, "'%s' '%s' --bogus", a, a);
    CHECK_EQ_INT(run(args), 2);
    /* No layer in common: an EXR with only an unrelated channel. */
    float junk[W * H] = { 0 };
    cv_exr_layer other = {
        .name = "specular", .channel_count = 1, .channels = { "Y" }, .type = CV_EXR_HALF, .planes = { junk }
    };
    CHECK_OK(cv_exr_write(scratch_path(2, "other.exr"),
                          &(cv_exr_desc){ .width = W, .height = H, .layer_count = 1, .layers = &other }));
    snprintf(args, sizeof args, "'%s' '%s'", a, scratch_path(2, "other.exr"));
    CHECK_EQ_INT(run(args), 2);
    CHECK(strstr(err_text, "no layer in common") != NULL);
    /* Not an EXR. */
    file_write_all(scratch_path(2, "text.exr"), "hello", 5);
    snprintf(args, sizeof args, "'%s' '%s'", a, scratch_path(2, "text.exr"));
    CHECK_EQ_INT(run(args), 2);
    CHECK(strstr(err_text, "text.exr") != NULL);
    /* Not a regular file: a FIFO is refused at once (it blocked in open). */
    CHECK(mkfifo(scratch_path(2, "fifo.exr"), 0600) == 0);
    snprintf(args, sizeof args, "'%s' '%s'", a, scratch_path(2, "fifo.exr"));
    CHECK_EQ_INT(run(args), 2);
    CHECK(strstr(err_text, "fifo.exr: is not a regular file (a FIFO)") != NULL);
    /* Out of memory says so, with the size (it read "big.exr: channel 'Y' of 4096x4096 floats",
     * like a description of the channel): a 64 MB plane under a 40 MB address-space limit. */
    enum { BIG = 4096 };
    float *zeros = calloc((size_t)BIG * BIG, sizeof(float));
    CHECK(zeros != NULL);
    cv_exr_layer big = {
        .name = "ao", .channel_count = 1, .channels = { "Y" }, .type = CV_EXR_HALF, .planes = { zeros }
    };
    CHECK_OK(cv_exr_write(scratch_path(2, "big.exr"),
                          &(cv_exr_desc){ .width = BIG, .height = BIG, .layer_count = 1, .layers = &big }));
    free(zeros);
    limit = "ulimit -v 40000;";
    if (run("--help") == 0) { /* a sanitizer's shadow memory cannot start under such a limit */
        snprintf(args, sizeof args, "'%s' '%s'", scratch_path(2, "big.exr"), scratch_path(2, "big.exr"));
        CHECK_EQ_INT(run(args), 2);
        CHECK(strstr(err_text, "CV_ERROR_OUT_OF_MEMORY: ") != NULL);
        CHECK(strstr(err_text, "big.exr: out of memory for channel 'ao.Y' (4096x4096 floats, 67108864 bytes)") !=
              NULL);
    } else {
        printf("corvid-compare cannot start under ulimit -v here: out of memory not checked\n");
    }
    limit = "";

    scratch_dir_remove();
    return check_report("corvid-compare");
}
