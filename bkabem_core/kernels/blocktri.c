/*
 * Batched complex block-tridiagonal solver with 4 x 4 blocks (the shaft matrix of a 4-DOF/node beam model).
 *
 * The exact reference solver of the FE model (bkabem_core/fe/solvers.py, ShaftSolver; why a loop of its own and
 * not LAPACK's banded solver: docs/performance.md). Bound by py_blocktri.c.
 *
 * Layout (all C-contiguous, complex double): for system b of B,
 *   D[b][i][4][4]  diagonal blocks, i = 0..nb-1
 *   U[b][i][4][4]  block (i, i+1), i = 0..nb-2      L[b][i][4][4]  block (i+1, i)
 *   f[b][i][4]     right-hand side, overwritten with the solution
 *   work: X[b][i][4][4] (nb-1 blocks), g[b][i][4] (nb)
 * Block LU (Thomas) with partial pivoting inside each 4 x 4 block. Returns the number of systems whose
 * smallest pivot was zero (their flag in bad[b] is 1 and their solution is not valid).
 */
#include "blocktri.h"

#include <math.h>
#include <string.h>

static inline double mag1(cplx z) { return fabs(creal(z)) + fabs(cimag(z)); }   /* LAPACK's |re|+|im| */

/* Solve S Y = R in place: S 4x4 (row-major), R 4 x m (row-major, leading dimension m). Gauss-Jordan with
 * partial pivoting. Returns the smallest |pivot| relative to the largest |S| entry. */
static double solve4(cplx S[16], cplx *R, int m)
{
    double scale = 0.0;
    for (int k = 0; k < 16; ++k) {
        double a = mag1(S[k]);
        if (a > scale) scale = a;
    }
    double worst = INFINITY;
    for (int k = 0; k < 4; ++k) {
        int p = k;
        double best = mag1(S[4 * k + k]);
        for (int r = k + 1; r < 4; ++r) {
            double a = mag1(S[4 * r + k]);
            if (a > best) { best = a; p = r; }
        }
        if (scale > 0.0 && best / scale < worst) worst = best / scale;
        if (best == 0.0) return 0.0;
        if (p != k) {
            for (int c = 0; c < 4; ++c) { cplx t = S[4 * k + c]; S[4 * k + c] = S[4 * p + c]; S[4 * p + c] = t; }
            for (int c = 0; c < m; ++c) { cplx t = R[m * k + c]; R[m * k + c] = R[m * p + c]; R[m * p + c] = t; }
        }
        cplx inv = 1.0 / S[4 * k + k];
        for (int c = k; c < 4; ++c) S[4 * k + c] *= inv;
        for (int c = 0; c < m; ++c) R[m * k + c] *= inv;
        for (int r = 0; r < 4; ++r) {
            if (r == k) continue;
            cplx fac = S[4 * r + k];
            if (fac == 0.0) continue;
            for (int c = k; c < 4; ++c) S[4 * r + c] -= fac * S[4 * k + c];
            for (int c = 0; c < m; ++c) R[m * r + c] -= fac * R[m * k + c];
        }
    }
    return worst;
}

/* One system: block LU (Thomas) with pivoting inside the blocks; f overwritten with x; returns the worst
 * pivot ratio. X ((nb-1) blocks) and g (nb x 4) are work space. */
static double solve_one(int nb, const cplx *Db, const cplx *Ub, const cplx *Lb, cplx *fb, cplx *Xb, cplx *gb)
{
    double worst = INFINITY;
    for (int i = 0; i < nb; ++i) {
        cplx S[16];
        cplx R[20];                         /* 4 x 5: [U_i | y_i] or 4 x 1 for the last block */
        memcpy(S, Db + 16 * i, sizeof S);
        int m = (i < nb - 1) ? 5 : 1;
        for (int r = 0; r < 4; ++r) {
            cplx y = fb[4 * i + r];
            if (i > 0) {                    /* S -= L_{i-1} X_{i-1};  y -= L_{i-1} g_{i-1} */
                const cplx *Lp = Lb + 16 * (i - 1);
                const cplx *Xp = Xb + 16 * (i - 1);
                const cplx *gp = gb + 4 * (i - 1);
                for (int c = 0; c < 4; ++c) {
                    cplx acc = 0.0;
                    for (int k = 0; k < 4; ++k) acc += Lp[4 * r + k] * Xp[4 * k + c];
                    S[4 * r + c] -= acc;
                }
                for (int k = 0; k < 4; ++k) y -= Lp[4 * r + k] * gp[k];
            }
            if (m == 5) {
                for (int c = 0; c < 4; ++c) R[5 * r + c] = Ub[16 * i + 4 * r + c];
                R[5 * r + 4] = y;
            } else {
                R[r] = y;
            }
        }
        double w = solve4(S, R, m);
        if (w < worst) worst = w;
        for (int r = 0; r < 4; ++r) {
            if (m == 5) {
                for (int c = 0; c < 4; ++c) Xb[16 * i + 4 * r + c] = R[5 * r + c];
                gb[4 * i + r] = R[5 * r + 4];
            } else {
                gb[4 * i + r] = R[r];
            }
        }
    }
    /* back substitution: x_last = g_last, x_i = g_i - X_i x_{i+1} */
    for (int r = 0; r < 4; ++r) fb[4 * (nb - 1) + r] = gb[4 * (nb - 1) + r];
    for (int i = nb - 2; i >= 0; --i) {
        for (int r = 0; r < 4; ++r) {
            cplx acc = gb[4 * i + r];
            for (int k = 0; k < 4; ++k) acc -= Xb[16 * i + 4 * r + k] * fb[4 * (i + 1) + k];
            fb[4 * i + r] = acc;
        }
    }
    return worst;
}

/*
 * The batch's solve, with the blocks built here from the real coefficient blocks of K, M, C, G:
 *   Z = K - w^2 M + i w (C + W G)      (w = excitation frequency, W = shaft speed, both rad/s, per system)
 * and the housing DOFs (no of them) condensed into the shaft node they touch:
 *   Z_node += -z_so z_os^T / z_oo,   f_node += -z_so f_o / z_oo,   x_o = (f_o - z_os . x_node) / z_oo.
 * coef_d: [4][nb*16] (K, M, C, G), coef_u, coef_l: [4][(nb-1)*16], coef_oo: [4][no], coef_so, coef_os: [4][no*4].
 * f_s (B, nb, 4) in: shaft forces, out: shaft displacements; f_o (B, no) housing forces; x_o (B, no) out.
 * D, U, L, X, g: work space for ONE system (each system is built and solved while it is in cache).
 */
int bt_solve_coef(int nb, int nbatch, const double *coef_d, const double *coef_u, const double *coef_l,
                  int no, const int *o_node, const double *coef_oo, const double *coef_so, const double *coef_os,
                  const double *w, const double *W, cplx *f_s, const cplx *f_o, cplx *x_o,
                  cplx *D, cplx *U, cplx *L, cplx *X, cplx *g, int *bad, double min_pivot_ratio)
{
    const int nd = nb * 16, nu = (nb - 1) * 16;
    int n_bad = 0;
    for (int b = 0; b < nbatch; ++b) {
        const double wb = w[b], w2 = wb * wb, Wb = W[b];
        cplx *Db = D, *Ub = U, *Lb = L;
        for (int k = 0; k < nd; ++k)
            Db[k] = (coef_d[k] - w2 * coef_d[nd + k]) + I * (wb * (coef_d[2 * nd + k] + Wb * coef_d[3 * nd + k]));
        for (int k = 0; k < nu; ++k) {
            Ub[k] = (coef_u[k] - w2 * coef_u[nu + k]) + I * (wb * (coef_u[2 * nu + k] + Wb * coef_u[3 * nu + k]));
            Lb[k] = (coef_l[k] - w2 * coef_l[nu + k]) + I * (wb * (coef_l[2 * nu + k] + Wb * coef_l[3 * nu + k]));
        }
        cplx *fb = f_s + (size_t)b * nb * 4;
        for (int o = 0; o < no; ++o) {
            cplx zoo = (coef_oo[o] - w2 * coef_oo[no + o]) + I * (wb * (coef_oo[2 * no + o] + Wb * coef_oo[3 * no + o]));
            cplx inv = 1.0 / zoo, zso[4], zos[4];
            for (int r = 0; r < 4; ++r) {
                int q = 4 * o + r, n4 = 4 * no;
                zso[r] = (coef_so[q] - w2 * coef_so[n4 + q]) + I * (wb * (coef_so[2 * n4 + q] + Wb * coef_so[3 * n4 + q]));
                zos[r] = (coef_os[q] - w2 * coef_os[n4 + q]) + I * (wb * (coef_os[2 * n4 + q] + Wb * coef_os[3 * n4 + q]));
            }
            cplx *blk = Db + 16 * o_node[o];
            cplx fo = f_o[(size_t)b * no + o] * inv;
            for (int r = 0; r < 4; ++r) {
                for (int c = 0; c < 4; ++c) blk[4 * r + c] -= zso[r] * zos[c] * inv;
                fb[4 * o_node[o] + r] -= zso[r] * fo;
            }
        }
        double worst = solve_one(nb, Db, Ub, Lb, fb, X, g);
        bad[b] = !(worst >= min_pivot_ratio);
        n_bad += bad[b];
        for (int o = 0; o < no; ++o) {
            cplx zoo = (coef_oo[o] - w2 * coef_oo[no + o]) + I * (wb * (coef_oo[2 * no + o] + Wb * coef_oo[3 * no + o]));
            cplx acc = f_o[(size_t)b * no + o];
            for (int r = 0; r < 4; ++r) {
                int q = 4 * o + r, n4 = 4 * no;
                cplx zos = (coef_os[q] - w2 * coef_os[n4 + q]) + I * (wb * (coef_os[2 * n4 + q] + Wb * coef_os[3 * n4 + q]));
                acc -= zos * fb[4 * o_node[o] + r];
            }
            x_o[(size_t)b * no + o] = acc / zoo;
        }
    }
    return n_bad;
}
