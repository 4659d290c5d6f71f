/* bench_frame_codec: what a presented frame costs to send, per codec of corvid_media,
 * beside the raw-planes path it replaces. For each size (640x360 and 1920x1080 by default)
 * and a moving, rendered-looking sequence (tests/media/synthetic_frame.c: gradients, hard
 * edges, grain), one row per path:
 *   raw f32     RGBA32F radiance planes as the renderer's outputs come back today (RAW codec:
 *               a copy), the baseline;
 *   zstd f32    the same planes, zstd level 1 (lossless: an EXR on request);
 *   raw rgba8   the tone-mapped 8-bit display image, uncompressed;
 *   png         that image, lossless RGB;
 *   jpeg q85    that image, JPEG quality 85, 4:2:0;
 *   h264        that image, H.264 at the default bitrate (width*height*fps/8000 kbit/s at
 *               60 fps), a stream whose first frame is the only IDR.
 * Each row: encode and decode ms (median over the frames), bytes per frame (mean; H.264's
 * first frame apart), what the link carries it in at --rate-mbit (100 Mbit/s by default),
 * and encode + transfer + decode; lossy rows give their worst frame's lowest channel PSNR.
 * One thread: each codec stream is single-threaded. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "corvid/frame_codec.h"
#include "corvid/parse.h"
#include "synthetic_frame.h"

#define MAX_SIZES 8
#define MAX_FRAMES 1000

typedef struct options {
    uint32_t widths[MAX_SIZES], heights[MAX_SIZES], size_count;
    uint32_t frames;
    double rate_mbit;
} options;

typedef struct row {
    const char *name;
    cv_codec codec;
    bool radiance; /* RGBA32F planes rather than the RGBA8 image */
    cv_encode_params params;
} row;

typedef struct result {
    double encode_ms, decode_ms, bytes, first_bytes, min_psnr;
} result;

static int compare_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, uint32_t n) {
    qsort(v, n, sizeof *v, compare_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* The sequence's frames, made before any timing. */
typedef struct sequence {
    uint32_t width, height, frames;
    uint8_t **rgba;
    float **radiance;
} sequence;

static bool run_row(const row *rw, const sequence *s, result *res) {
    cv_encoder *e = NULL;
    cv_decoder *d = NULL;
    if (cv_encoder_create(rw->codec, s->width, s->height, &e) != CV_OK || cv_decoder_create(rw->codec, &d) != CV_OK) {
        fprintf(stderr, "bench_frame_codec: %s: %s\n", rw->name, cv_last_error());
        cv_encoder_destroy(e);
        return false;
    }
    double *enc = calloc(s->frames, sizeof *enc), *dec = calloc(s->frames, sizeof *dec);
    size_t stride = (size_t)s->width * (rw->radiance ? 16u : 4u);
    bool ok = enc && dec;
    double bytes = 0;
    *res = (result){ .min_psnr = INFINITY };
    for (uint32_t f = 0; ok && f < s->frames; f++) {
        const uint8_t *pixels = rw->radiance ? (const uint8_t *)s->radiance[f] : s->rgba[f];
        cv_encoded frame = { 0 };
        uint8_t *out = NULL;
        size_t n = 0;
        uint32_t w = 0, h = 0;
        ok = cv_encoder_encode(e, pixels, stride, &rw->params, &frame) == CV_OK;
        double t0 = bench_now();
        ok = ok && cv_decoder_decode(d, frame.data, frame.size, &out, &n, &w, &h) == CV_OK;
        dec[f] = (bench_now() - t0) * 1e3;
        enc[f] = frame.encode_ms;
        if (ok && f == 0)
            res->first_bytes = (double)frame.size;
        else
            bytes += (double)frame.size;
        if (ok && !rw->radiance && rw->codec != CV_CODEC_RAW && rw->codec != CV_CODEC_PNG) {
            frame_diff diff = frame_compare(pixels, out, s->width, s->height);
            res->min_psnr = fmin(res->min_psnr, diff.min_psnr_db);
        }
        if (!ok)
            fprintf(stderr, "bench_frame_codec: %s frame %u: %s\n", rw->name, f, cv_last_error());
        free(out);
        cv_encoded_free(&frame);
    }
    if (ok) {
        res->encode_ms = median(enc, s->frames);
        res->decode_ms = median(dec, s->frames);
        res->bytes = s->frames > 1 ? bytes / (s->frames - 1) : res->first_bytes;
    }
    free(enc);
    free(dec);
    cv_encoder_destroy(e);
    cv_decoder_destroy(d);
    return ok;
}

static void print_row(const row *rw, const result *r, const result *baseline, double rate_mbit) {
    double link_ms = r->bytes * 8.0 / (rate_mbit * 1e6) * 1e3;
    double total = r->encode_ms + link_ms + r->decode_ms;
    double base_total = baseline->encode_ms + baseline->bytes * 8.0 / (rate_mbit * 1e6) * 1e3 + baseline->decode_ms;
    char psnr[32] = "lossless";
    if (isfinite(r->min_psnr))
        snprintf(psnr, sizeof psnr, "%.1f dB", r->min_psnr);
    char first[48] = "";
    if (rw->codec == CV_CODEC_H264)
        snprintf(first, sizeof first, " (IDR %.0f)", r->first_bytes);
    printf(
        "  %-10s enc %7.2f ms  dec %7.2f ms  %11.0f B/frame%-13s link %8.2f ms  total %8.2f ms (%6.1fx less "
        "than raw f32)  %s\n",
        rw->name, r->encode_ms, r->decode_ms, r->bytes, first, link_ms, total, base_total / total, psnr);
}

static bool make_sequence(uint32_t w, uint32_t h, uint32_t frames, sequence *s) {
    *s = (sequence){ .width = w, .height = h, .frames = frames };
    s->rgba = calloc(frames, sizeof *s->rgba);
    s->radiance = calloc(frames, sizeof *s->radiance);
    for (uint32_t f = 0; s->rgba && s->radiance && f < frames; f++) {
        s->rgba[f] = malloc((size_t)w * h * 4);
        s->radiance[f] = malloc((size_t)w * h * 16);
        if (!s->rgba[f] || !s->radiance[f])
            return false;
        synthetic_frame(s->rgba[f], w, h, f, 1);
        synthetic_radiance(s->radiance[f], w, h, f);
    }
    return s->rgba && s->radiance;
}

static void free_sequence(sequence *s) {
    for (uint32_t f = 0; f < s->frames; f++) {
        free(s->rgba ? s->rgba[f] : NULL);
        free(s->radiance ? s->radiance[f] : NULL);
    }
    free(s->rgba);
    free(s->radiance);
}

static bool parse_size(const char *text, uint32_t *w, uint32_t *h) {
    char a[16], b[16];
    const char *x = strchr(text, 'x');
    uint64_t wv, hv;
    if (!x || x == text || (size_t)(x - text) >= sizeof a || strlen(x + 1) >= sizeof b)
        return false;
    snprintf(a, sizeof a, "%.*s", (int)(x - text), text);
    snprintf(b, sizeof b, "%s", x + 1);
    if (!cv_parse_uint(a, 2, CV_CODEC_MAX_SIDE, &wv) || !cv_parse_uint(b, 2, CV_CODEC_MAX_SIDE, &hv) || wv % 2 ||
        hv % 2)
        return false;
    *w = (uint32_t)wv;
    *h = (uint32_t)hv;
    return true;
}

/* false: print the usage (and exit 2, or 0 for --help). */
static bool parse(int argc, char **argv, options *o, bool *help) {
    *o = (options){
        .widths = { 640, 1920 }, .heights = { 360, 1080 }, .size_count = 2, .frames = 20, .rate_mbit = 100
    };
    *help = false;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        uint64_t n;
        if (!strcmp(a, "--help")) {
            *help = true;
            return false;
        }
        if (!strcmp(a, "--quick")) { /* a smoke run: the small size, 3 frames */
            o->size_count = 1;
            o->frames = 3;
            continue;
        }
        if (!strcmp(a, "--frames") && cv_parse_uint(v, 2, MAX_FRAMES, &n)) {
            o->frames = (uint32_t)n;
        } else if (!strcmp(a, "--rate-mbit") && cv_parse_uint(v, 1, 1000000, &n)) {
            o->rate_mbit = (double)n;
        } else if (!strcmp(a, "--sizes") && v) {
            o->size_count = 0;
            char list[256];
            snprintf(list, sizeof list, "%s", v);
            for (char *save = NULL, *t = strtok_r(list, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
                if (o->size_count == MAX_SIZES ||
                    !parse_size(t, &o->widths[o->size_count], &o->heights[o->size_count]))
                    return false;
                o->size_count++;
            }
            if (o->size_count == 0)
                return false;
        } else {
            return false;
        }
        i++;
    }
    return true;
}

int main(int argc, char **argv) {
    options o;
    bool help;
    if (!parse(argc, argv, &o, &help)) {
        fprintf(help ? stdout : stderr,
                "usage: bench_frame_codec [--sizes WxH,...] (even sides; default 640x360,1920x1080)\n"
                "                         [--frames N] (2..%d, default 20) [--rate-mbit N] (default 100)\n"
                "                         [--quick] (640x360, 3 frames)\n",
                MAX_FRAMES);
        return help ? 0 : 2;
    }
    char machine[256];
    bench_machine(machine, sizeof machine);
    printf("bench_frame_codec: %s; %u frames a row, link %.0f Mbit/s\n", machine, o.frames, o.rate_mbit);
    const row rows[] = {
        { "raw f32", CV_CODEC_RAW, true, { 0 } },
        { "zstd f32", CV_CODEC_ZSTD, true, { .zstd_level = 1 } },
        { "raw rgba8", CV_CODEC_RAW, false, { 0 } },
        { "png", CV_CODEC_PNG, false, { 0 } },
        { "jpeg q85", CV_CODEC_JPEG, false, { .quality = 85 } },
        { "h264", CV_CODEC_H264, false, { 0 } },
    };
    bool ok = true;
    for (uint32_t i = 0; ok && i < o.size_count; i++) {
        sequence s;
        ok = make_sequence(o.widths[i], o.heights[i], o.frames, &s);
        printf("\n%ux%u:\n", o.widths[i], o.heights[i]);
        result baseline = { 0 };
        for (size_t k = 0; ok && k < sizeof rows / sizeof rows[0]; k++) {
            result r;
            ok = run_row(&rows[k], &s, &r);
            if (k == 0)
                baseline = r;
            if (ok)
                print_row(&rows[k], &r, &baseline, o.rate_mbit);
        }
        free_sequence(&s);
    }
    return ok ? 0 : 1;
}
