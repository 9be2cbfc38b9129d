/*
 * Pole-residue sum of the order-wise modal form (bkabem_core/fe/modal.py, OrderModalForm), in its
 * mode-acceleration form:
 *
 *     X[k][u] = X0[k][u] + i w[k] sum_r E'[k][r][u] / (i w[k] - lambda[k][r]),     u = 0..7
 *
 * for K orders and R poles per order, 8 outputs (fewer are zero-padded by the caller); X0 is the exact static
 * response and E' = E / lambda, all in double (float32 residues lose 2e-5 of a channel's largest order on the
 * reduced model, whose static residual vectors make the pole sum cancel). Bound by py_modalsum.c.
 *
 * Layout (C-contiguous; real and imaginary parts in separate arrays so that the 8 outputs of a pole are two
 * 4-wide vectors): w[K] [rad/s]; lam_re, lam_im [K][R] double; e_re, e_im [K][R][8] double; x0_re, x0_im [K][8]
 * double; results x_re, x_im [K][8] double. GCC builds an AVX2 and a baseline clone, picked at load time.
 */
#include "modalsum.h"

#include <stdint.h>

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define CLONES __attribute__((target_clones("avx2", "default")))
#else
#define CLONES
#endif

typedef double v4 __attribute__((vector_size(32)));

/* unaligned 4-double load / store (macros: AVX values must not cross a function boundary in the baseline clone) */
#define LOAD4(v, p) __builtin_memcpy(&(v), (p), sizeof(v4))
#define STORE4(p, v) __builtin_memcpy((p), &(v), sizeof(v4))

/* (xr0, xr1, xi0, xi1) += g E'_r over the 8 outputs of pole r, g = gr + i gi. A macro: AVX values must not cross
 * a function boundary in the baseline clone. */
#define ACC_POLE(gr, gi, r, xr0, xr1, xi0, xi1)                                                          \
    do {                                                                                                  \
        v4 pr0_, pr1_, pi0_, pi1_;                                                                        \
        LOAD4(pr0_, er + 8 * (r));                                                                        \
        LOAD4(pr1_, er + 8 * (r) + 4);                                                                    \
        LOAD4(pi0_, ei + 8 * (r));                                                                        \
        LOAD4(pi1_, ei + 8 * (r) + 4);                                                                    \
        xr0 += (gr) * pr0_ - (gi) * pi0_;                                                                 \
        xr1 += (gr) * pr1_ - (gi) * pi1_;                                                                 \
        xi0 += (gr) * pi0_ + (gi) * pr0_;                                                                 \
        xi1 += (gr) * pi1_ + (gi) * pr1_;                                                                 \
    } while (0)

/* Longest pole list per order the stack buffers hold (2 x ndof; 60 DOF -> 120). */
#define MAXR MODAL_MAXR

/* The Cauchy factors g_r = 1 / (i w - lambda_r) of an order first (a loop without carried dependency: divisions
 * vectorise), then the sum over poles two at a time into two accumulator sets (instruction-level parallelism). */
CLONES
int modal_sum8(int nk, int nr, const double *w, const double *lam_re, const double *lam_im,
               const double *e_re, const double *e_im, const double *x0_re, const double *x0_im,
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
        const double *er = e_re + (long)k * nr * 8, *ei = e_im + (long)k * nr * 8;
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

/*
 * Speed-cell form (fe/modal.py, SpeedCells): within one cell of shaft speed, t in [-1, 1], every order's response is
 *
 *     X[k][u] = sum_d c[k][d][u] T_d(t) + sum_{near poles of k} E[k][r][u] / (i w[k] - lambda[k][r])
 *
 * (Chebyshev interpolant of the direct term plus all far poles, and the few poles near the cell exactly; the
 * interpolation error is bounded per pole when the cell is made, see fe/modal.py). Everything in double: the cost
 * is (D + 1) complex multiply-adds per order and output plus the near poles.
 *
 * A cell (ModalCell, made once per cell by py_modalsum.c): K orders, nd Chebyshev coefficients, nu outputs;
 * w_per_hz [K] (rad/s per Hz of shaft speed); coef_re, coef_im [K][nd][8]; near_start [K + 1] int32 (poles of order
 * k: near_start[k] .. near_start[k+1] - 1 of the packed arrays); near_lr, near_li [n_near]; near_er, near_ei
 * [n_near][8]. Result x: K x nu complex double, interleaved (numpy complex128, nu <= 8).
 */
#define MAXD MODAL_MAXD

CLONES
int cell_sum8(const ModalCell *c, double f, double t, double *x)
{
    const int nk = c->nk, nd = c->nd, nu = c->nu;
    const double *wph = c->w_per_hz, *coef_re = c->coef_re, *coef_im = c->coef_im;
    const int *near_start = c->near_start;
    const double *near_lr = c->near_lr, *near_li = c->near_li, *near_er = c->near_er, *near_ei = c->near_ei;
    double tc[MAXD], xr[8], xi[8];
    if (nd < 1 || nd > MAXD || nu < 1 || nu > 8) return -1;
    tc[0] = 1.0;
    if (nd > 1) tc[1] = t;
    for (int d = 2; d < nd; ++d) tc[d] = 2.0 * t * tc[d - 1] - tc[d - 2];
    for (int k = 0; k < nk; ++k) {
        const double *cr = coef_re + (long)k * nd * 8, *ci = coef_im + (long)k * nd * 8;
        v4 ar0 = {0.0, 0.0, 0.0, 0.0}, ar1 = ar0, ai0 = ar0, ai1 = ar0;
        for (int d = 0; d < nd; ++d) {
            v4 a, b, c, e;
            LOAD4(a, cr + 8 * d); LOAD4(b, cr + 8 * d + 4);
            LOAD4(c, ci + 8 * d); LOAD4(e, ci + 8 * d + 4);
            ar0 += tc[d] * a; ar1 += tc[d] * b;
            ai0 += tc[d] * c; ai1 += tc[d] * e;
        }
        const double wk = wph[k] * f;
        for (int r = near_start[k]; r < near_start[k + 1]; ++r) {
            double zr = -near_lr[r], zi = wk - near_li[r];
            double s = 1.0 / (zr * zr + zi * zi);
            double gr = zr * s, gi = -zi * s;        /* 1 / (i w - lambda) */
            v4 pr0, pr1, pi0, pi1;
            LOAD4(pr0, near_er + 8 * (long)r); LOAD4(pr1, near_er + 8 * (long)r + 4);
            LOAD4(pi0, near_ei + 8 * (long)r); LOAD4(pi1, near_ei + 8 * (long)r + 4);
            ar0 += gr * pr0 - gi * pi0; ar1 += gr * pr1 - gi * pi1;
            ai0 += gr * pi0 + gi * pr0; ai1 += gr * pi1 + gi * pr1;
        }
        STORE4(xr, ar0); STORE4(xr + 4, ar1);
        STORE4(xi, ai0); STORE4(xi + 4, ai1);
        double *xk = x + 2 * (long)k * nu;
        for (int u = 0; u < nu; ++u) {
            xk[2 * u] = xr[u];
            xk[2 * u + 1] = xi[u];
        }
    }
    return 0;
}
