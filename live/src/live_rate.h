/* Bandwidth adaptation of the live's encoder: from the consumer's measured
 * link and the encoded sizes, the JPEG quality and the H.264 bitrate that keep
 * frame bytes * fps under CV_LIVE_LINK_SHARE of the link (docs/live.md).
 * Plain arithmetic: no clock, no lock; the live calls it under its own. */
#ifndef CORVID_LIVE_RATE_H
#define CORVID_LIVE_RATE_H

#include <stddef.h>
#include <stdint.h>

#define CV_LIVE_QUALITY_MIN 40u
#define CV_LIVE_QUALITY_MAX 90u
/* The share of the link the frames may take: the rest for the viewer's own
 * traffic, TCP's headers and the link's jitter. */
#define CV_LIVE_LINK_SHARE 0.8
/* The frame rate budgets are figured at no less than this: a view that has
 * converged renders no frames, yet its next motion must not start at a
 * quality the link cannot carry. */
#define CV_LIVE_RATE_MIN_FPS 10.0
/* The lowest bitrate chosen for H.264, kbit/s. */
#define CV_LIVE_MIN_BITRATE_KBPS 100u

typedef struct live_rate {
    uint32_t quality;          /* JPEG: the quality of the next frame */
    uint32_t bitrate_kbps;     /* H.264: the target of the next frame; 0 = the encoder's default */
    uint32_t bitrate_cap_kbps; /* the starting bitrate when one was given (never exceeded), else 0 */
    double link_bytes_per_s;   /* last reported; 0 = unknown (no adaptation) */
} live_rate;

/* quality: the starting JPEG quality (0 = 85; clamped to the range);
 * bitrate_kbps: the starting H.264 bitrate (0 = the encoder's default). */
void live_rate_init(live_rate *r, uint32_t quality, uint32_t bitrate_kbps);

/* A new link measurement: the H.264 bitrate follows it at once. */
void live_rate_link(live_rate *r, double bytes_per_s);

/* A JPEG frame of `bytes` at r->quality, frames going out at `fps`: moves
 * the quality toward the budget (down fast, up one step a frame). */
void live_rate_jpeg_frame(live_rate *r, size_t bytes, double fps);

#endif
