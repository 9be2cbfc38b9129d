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
            double gr = gre[r], gi = gim[r], hr = gre[r + 1], hi = gim[r + 1];
            f4 a, b, c, d, e, f, g, h;
            __builtin_memcpy(&a, er + 8 * r, sizeof a);
            __builtin_memcpy(&b, er + 8 * r + 4, sizeof b);
            __builtin_memcpy(&c, ei + 8 * r, sizeof c);
            __builtin_memcpy(&d, ei + 8 * r + 4, sizeof d);
            __builtin_memcpy(&e, er + 8 * r + 8, sizeof e);
            __builtin_memcpy(&f, er + 8 * r + 12, sizeof f);
            __builtin_memcpy(&g, ei + 8 * r + 8, sizeof g);
            __builtin_memcpy(&h, ei + 8 * r + 12, sizeof h);
            v4 pr0 = __builtin_convertvector(a, v4), pr1 = __builtin_convertvector(b, v4);
            v4 pi0 = __builtin_convertvector(c, v4), pi1 = __builtin_convertvector(d, v4);
            v4 qr0 = __builtin_convertvector(e, v4), qr1 = __builtin_convertvector(f, v4);
            v4 qi0 = __builtin_convertvector(g, v4), qi1 = __builtin_convertvector(h, v4);
            ar0 += gr * pr0 - gi * pi0;
            ar1 += gr * pr1 - gi * pi1;
            ai0 += gr * pi0 + gi * pr0;
            ai1 += gr * pi1 + gi * pr1;
            br0 += hr * qr0 - hi * qi0;
            br1 += hr * qr1 - hi * qi1;
            bi0 += hr * qi0 + hi * qr0;
            bi1 += hr * qi1 + hi * qr1;
        }
        ar0 += br0; ar1 += br1; ai0 += bi0; ai1 += bi1;
        for (; r < nr; ++r) {
            double gr = gre[r], gi = gim[r];
            f4 a, b, c, d;
            __builtin_memcpy(&a, er + 8 * r, sizeof a);
            __builtin_memcpy(&b, er + 8 * r + 4, sizeof b);
            __builtin_memcpy(&c, ei + 8 * r, sizeof c);
            __builtin_memcpy(&d, ei + 8 * r + 4, sizeof d);
            v4 pr0 = __builtin_convertvector(a, v4), pr1 = __builtin_convertvector(b, v4);
            v4 pi0 = __builtin_convertvector(c, v4), pi1 = __builtin_convertvector(d, v4);
            ar0 += gr * pr0 - gi * pi0;
            ar1 += gr * pr1 - gi * pi1;
            ai0 += gr * pi0 + gi * pr0;
            ai1 += gr * pi1 + gi * pr1;
        }
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
