/* The batched complex block-tridiagonal solver of the FE model's exact reference (blocktri.c). */
#ifndef BKABEM_BLOCKTRI_H
#define BKABEM_BLOCKTRI_H

#include <complex.h>

typedef double complex cplx;

/* B systems Z x = f of nb shaft nodes (4 x 4 blocks) with no housing DOFs condensed into the nodes o_node (see
 * blocktri.c for the layout); f_s overwritten with the shaft displacements, x_o the housing ones; D, U, L, X, g work
 * space for one system; bad[b] = 1 where the smallest pivot ratio is below min_pivot_ratio. Returns the number of
 * bad systems. */
int bt_solve_coef(int nb, int nbatch, const double *coef_d, const double *coef_u, const double *coef_l,
                  int no, const int *o_node, const double *coef_oo, const double *coef_so, const double *coef_os,
                  const double *w, const double *W, cplx *f_s, const cplx *f_o, cplx *x_o,
                  cplx *D, cplx *U, cplx *L, cplx *X, cplx *g, int *bad, double min_pivot_ratio);

#endif
