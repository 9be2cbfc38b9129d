/*
 * Pole-residue sum of the order-wise modal form (bkabem_core/harmonic.py, OrderModalForm), in its
 * mode-acceleration form:
 *
 *     X[k][u] = X0[k][u] + i w[k] sum_r E'[k][r][u] / (i w[k] - lambda[k][r]),     u = 0..7
 *
 * for K orders and R poles per order, 8 outputs (fewer are zero-padded by the caller); X0 is the exact static
 * response and E' = E / lambda, stored in float32 (sums in double). Why C: the synthesiser evaluates this at
 * every new shaft speed (every chunk when streaming), K R 8 = 50 x 120 x 8 complex multiply-adds on the embedded
 * case: numpy's batched matmul plus the Cauchy factors take ~120 us, this loop ~50 us (BENCHMARKS.md). Why
 * float32 residues: the sum is memory-bound next to the synthesiser's tables (768 KB of double residues fall out
 * of a 1 MB L2 cache between chunks); the mode-acceleration form keeps the float32 round-off below 1e-6 of a
 * channel's largest order (the plain form E / (i w - lambda) loses 3e-4 near the static limit in float32).
 * Loaded with ctypes; the module init below only exists so that setuptools builds and installs it.
 *
 * Layout (C-contiguous; real and imaginary parts in separate arrays so that the 8 outputs of a pole are two
 * 4-wide vectors): w[K] [rad/s]; lam_re, lam_im [K][R] double; e_re, e_im [K][R][8] float; x0_re, x0_im [K][8]
 * double; results x_re, x_im [K][8] double. GCC builds an AVX2 and a baseline clone, picked at load time.
 */
#include <Python.h>

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define CLONES __attribute__((target_clones("avx2", "default")))
#else
#define CLONES
#endif

typedef double v4 __attribute__((vector_size(32)));

/* unaligned 4-double load / store (macros: AVX values must not cross a function boundary in the baseline clone) */
#define LOAD4(v, p) __builtin_memcpy(&(v), (p), sizeof(v4))
#define STORE4(p, v) __builtin_memcpy((p), &(v), sizeof(v4))

typedef float f4 __attribute__((vector_size(16)));

/* (xr0, xr1, xi0, xi1) += g E'_r over the 8 outputs of pole r (float32 residues widened to double),
 * g = gr + i gi. A macro: AVX values must not cross a function boundary in the baseline clone. */
#define ACC_POLE(gr, gi, r, xr0, xr1, xi0, xi1)                                                          \
    do {                                                                                                  \
        f4 a_, b_, c_, d_;                                                                                \
        __builtin_memcpy(&a_, er + 8 * (r), sizeof a_);                                                   \
        __builtin_memcpy(&b_, er + 8 * (r) + 4, sizeof b_);                                               \
        __builtin_memcpy(&c_, ei + 8 * (r), sizeof c_);                                                   \
        __builtin_memcpy(&d_, ei + 8 * (r) + 4, sizeof d_);                                               \
        v4 pr0_ = __builtin_convertvector(a_, v4), pr1_ = __builtin_convertvector(b_, v4);                \
        v4 pi0_ = __builtin_convertvector(c_, v4), pi1_ = __builtin_convertvector(d_, v4);                \
        xr0 += (gr) * pr0_ - (gi) * pi0_;                                                                 \
        xr1 += (gr) * pr1_ - (gi) * pi1_;                                                                 \
        xi0 += (gr) * pi0_ + (gi) * pr0_;                                                                 \
        xi1 += (gr) * pi1_ + (gi) * pr1_;                                                                 \
    } while (0)

/* Longest pole list per order the stack buffers hold (2 x ndof; 60 DOF -> 120). */
#define MAXR 1024

/* The Cauchy factors g_r = 1 / (i w - lambda_r) of an order first (a loop without carried dependency: divisions
 * vectorise), then the sum over poles two at a time into two accumulator sets (instruction-level parallelism):
 * 30 % faster than one pass with a division per pole. */
CLONES
int modal_sum8(int nk, int nr, const double *w, const double *lam_re, const double *lam_im,
               const float *e_re, const float *e_im, const double *x0_re, const double *x0_im,
               double *x_re, double *x_im)
{
    double gre[MAXR], gim[MAXR];
    if (nr > MAXR) return -1;
    for (int k = 0; k < nk; ++k) {
        const double *lr = lam_re + (long)k * nr, *li = lam_im + (long)k * nr;
        const double wk = w[k];
        for (int r = 0; r < nr; ++r) {           /* vectorisable: no loop-carried dependency */
            double zr = -lr[r], zi = wk - li[r];
            double s = 1.0 / (zr * zr + zi * zi);
            gre[r] = zr * s;
            gim[r] = -zi * s;
        }
        v4 ar0 = {0.0, 0.0, 0.0, 0.0}, ar1 = ar0, ai0 = ar0, ai1 = ar0;
        v4 br0 = ar0, br1 = ar0, bi0 = ar0, bi1 = ar0;
        const float *er = e_re + (long)k * nr * 8, *ei = e_im + (long)k * nr * 8;
        int r = 0;
        for (; r + 1 < nr; r += 2) {
            ACC_POLE(gre[r], gim[r], r, ar0, ar1, ai0, ai1);
            ACC_POLE(gre[r + 1], gim[r + 1], r + 1, br0, br1, bi0, bi1);
        }
        ar0 += br0; ar1 += br1; ai0 += bi0; ai1 += bi1;
        for (; r < nr; ++r) ACC_POLE(gre[r], gim[r], r, ar0, ar1, ai0, ai1);
        /* X = X0 + i w S */
        v4 x0r0, x0r1, x0i0, x0i1;
        LOAD4(x0r0, x0_re + 8 * k); LOAD4(x0r1, x0_re + 8 * k + 4);
        LOAD4(x0i0, x0_im + 8 * k); LOAD4(x0i1, x0_im + 8 * k + 4);
        v4 xr0 = x0r0 - wk * ai0, xr1 = x0r1 - wk * ai1;
        v4 xi0 = x0i0 + wk * ar0, xi1 = x0i1 + wk * ar1;
        STORE4(x_re + 8 * k, xr0); STORE4(x_re + 8 * k + 4, xr1);
        STORE4(x_im + 8 * k, xi0); STORE4(x_im + 8 * k + 4, xi1);
    }
    return 0;
}

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_modalsum",
                                       "C kernel loaded with ctypes (see bkabem_core/harmonic.py)", -1, NULL};

PyMODINIT_FUNC PyInit__modalsum(void) { return PyModule_Create(&moduledef); }
