/*
 * Pole-residue sum of the order-wise modal form (bkabem_core/harmonic.py, OrderModalForm):
 *
 *     X[k][u] = D[k][u] + sum_r E[k][r][u] / (i w[k] - lambda[k][r]),     u = 0..7
 *
 * for K orders and R poles per order, 8 outputs (fewer are zero-padded by the caller). Why C: the synthesiser
 * evaluates this at every new shaft speed (every chunk when streaming), K R 8 = 50 x 120 x 8 complex
 * multiply-adds on the embedded case: numpy's batched matmul plus the Cauchy factors take ~120 us, this loop
 * ~50 us (BENCHMARKS.md). Loaded with ctypes; the module init below only exists so that setuptools builds and
 * installs it as an extension.
 *
 * Layout (C-contiguous doubles; real and imaginary parts in separate arrays so that the 8 outputs of a pole are
 * two 4-wide vectors): w[K] [rad/s]; lam_re, lam_im [K][R]; e_re, e_im [K][R][8]; d_re, d_im [K][8]; results
 * x_re, x_im [K][8]. GCC builds an AVX2 and a baseline clone and picks one at load time.
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

CLONES
int modal_sum8(int nk, int nr, const double *w, const double *lam_re, const double *lam_im,
               const double *e_re, const double *e_im, const double *d_re, const double *d_im,
               double *x_re, double *x_im)
{
    for (int k = 0; k < nk; ++k) {
        v4 ar0, ar1, ai0, ai1;
        LOAD4(ar0, d_re + 8 * k);
        LOAD4(ar1, d_re + 8 * k + 4);
        LOAD4(ai0, d_im + 8 * k);
        LOAD4(ai1, d_im + 8 * k + 4);
        const double *lr = lam_re + (long)k * nr, *li = lam_im + (long)k * nr;
        const double *er = e_re + (long)k * nr * 8, *ei = e_im + (long)k * nr * 8;
        for (int r = 0; r < nr; ++r) {
            /* g = 1 / (i w - lambda) = (zr - i zi) / (zr^2 + zi^2),  z = -Re(lambda) + i (w - Im(lambda)) */
            double zr = -lr[r], zi = w[k] - li[r];
            double s = 1.0 / (zr * zr + zi * zi);
            double gr = zr * s, gi = -zi * s;
            v4 pr0, pr1, pi0, pi1;
            LOAD4(pr0, er + 8 * r);
            LOAD4(pr1, er + 8 * r + 4);
            LOAD4(pi0, ei + 8 * r);
            LOAD4(pi1, ei + 8 * r + 4);
            ar0 += gr * pr0 - gi * pi0;
            ar1 += gr * pr1 - gi * pi1;
            ai0 += gr * pi0 + gi * pr0;
            ai1 += gr * pi1 + gi * pr1;
        }
        STORE4(x_re + 8 * k, ar0);
        STORE4(x_re + 8 * k + 4, ar1);
        STORE4(x_im + 8 * k, ai0);
        STORE4(x_im + 8 * k + 4, ai1);
    }
    return 0;
}

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_modalsum",
                                       "C kernel loaded with ctypes (see bkabem_core/harmonic.py)", -1, NULL};

PyMODINIT_FUNC PyInit__modalsum(void) { return PyModule_Create(&moduledef); }
