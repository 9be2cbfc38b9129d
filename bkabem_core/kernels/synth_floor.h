/*
 * The broadband floor of the synthesiser (bkabem_core/synth/floor.py), in C (synth_floor.c):
 *
 *   floor_block_f32 / synth_floor_render  the floor of samples n0 .. n0 + m - 1: overlapping grains g of 2 S samples
 *                         from g S, each a circular window into one of the precomputed shaped-noise frames (L x C
 *                         int16 each, times scale[c]), weighted by the sine window w(t) = sin(pi t / 2 S) (win: 2 S
 *                         values), so that the two grains over any sample have w^2 + w^2 = 1. G grains given as
 *                         (g, frame index, offset) in grains[3 G]. out: m x C float32, written.
 *   synth_floor_spectrum  one frame's spectrum: the complex amplitudes of the four force pairs at every line,
 *                         A = s (z_re + i z_im), from the sensor noise's generator (8 normals a line: the 8
 *                         "channels" of sample k of the frame's stream, z[0..3] the real parts of force pairs 0..3,
 *                         z[4..7] the imaginary parts), times the transfer and summed over the pairs in the same
 *                         pass, float32 (complex64 out);
 *   synth_floor_quantise  max |x| per channel over all frames, scale = max / 32767, q = rint(x inv) in float32 with
 *                         inv = 32767 / max (double, rounded to float), clipped to +-32767 (the numpy fallback's
 *                         operations, bit for bit).
 * The inverse FFT between them stays scipy.fft's (float32 in, float32 out).
 */
#ifndef BKABEM_SYNTH_FLOOR_H
#define BKABEM_SYNTH_FLOOR_H

#include <stdint.h>

void floor_block_f32(int64_t m, int64_t C, int64_t n0, int64_t S, int64_t L, const int16_t *frames,
                     const float *scale, const float *win, int64_t G, const int64_t *grains, float *out);
int synth_floor_render(int64_t m, int64_t C, int64_t n0, int64_t S, int64_t L, const int16_t *frames,
                       const float *win, int64_t G, const int64_t *grains, float *out, const float *scale);
/* out[k][c] = sum_j T[j][k][c] a_j(k), k < F (T: 4 x F x C complex64 as float pairs); avx2 = 0: the scalar
 * generator (the same bits). */
int synth_floor_spectrum(uint64_t key, int64_t F, int64_t C, const float *T, double s, float *out, int avx2);
int synth_floor_quantise(int64_t n, int64_t C, const float *x, int16_t *q, float *scale);

#endif
