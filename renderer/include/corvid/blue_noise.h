/* A 64x64 blue-noise rank mask (void and cluster, Ulichney 1993), for the
 * renderer's sample points (render.raygen).
 *
 * Every cell gets a rank in 0..4095 (a permutation): cells of nearby ranks lie
 * far apart on the torus, so thresholding the mask at any level gives evenly
 * spread points, and the ranks as values have little low-frequency energy.
 * The mask is computed in integers (the energy kernel is a table of integers,
 * ties go to the lowest index), so it is the same bytes on every host. The
 * renderer computes it once per renderer (about 30 ms) and loads it on every
 * device as a buffer that render.raygen reads.
 *
 *   uint16_t ranks[CV_BLUE_NOISE_CELLS];
 *   cv_blue_noise_ranks(ranks);                 // ranks[y * 64 + x]
 *   float u = (ranks[y % 64 * 64 + x % 64] + 0.5f) / CV_BLUE_NOISE_CELLS;
 */
#ifndef CORVID_BLUE_NOISE_H
#define CORVID_BLUE_NOISE_H

#include <stdint.h>

#define CV_BLUE_NOISE_SIZE 64u
#define CV_BLUE_NOISE_CELLS (CV_BLUE_NOISE_SIZE * CV_BLUE_NOISE_SIZE)

/* Fills out[y * CV_BLUE_NOISE_SIZE + x] with the mask's ranks. Pure: no state,
 * no allocation. */
void cv_blue_noise_ranks(uint16_t out[CV_BLUE_NOISE_CELLS]);

#endif
