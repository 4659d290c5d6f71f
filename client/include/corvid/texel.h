/* Texel encoding: float RGBA -> the bytes of one texel of a cv_format, as a GPU
 * would store it (round to nearest; unorm clamped; half and the packed
 * 11/11/10 float format with their own rounding). Used by the mock backend's
 * emulated clears and by tests that build expected images. */
#ifndef CORVID_TEXEL_H
#define CORVID_TEXEL_H

#include "corvid/types.h"

uint16_t cv_float_to_half(float f);
float cv_half_to_float(uint16_t h);
/* Writes cv_format_bytes(format) bytes to out. */
void cv_texel_encode(cv_format format, const float rgba[4], void *out);

#endif
