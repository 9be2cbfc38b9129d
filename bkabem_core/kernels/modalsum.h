/* The pole-residue sums of the order-wise modal form (modalsum.c). */
#ifndef BKABEM_MODALSUM_H
#define BKABEM_MODALSUM_H

/* Longest pole list per order the stack buffers hold (2 x ndof). */
#define MODAL_MAXR 1024
/* Most Chebyshev coefficients of a speed cell. */
#define MODAL_MAXD 64

/* X = X0 + i w S for nk orders of nr poles (see modalsum.c for the layout). Returns 0, -1 if nr > MODAL_MAXR. */
int modal_sum8(int nk, int nr, const double *w, const double *lam_re, const double *lam_im,
               const double *e_re, const double *e_im, const double *x0_re, const double *x0_im,
               double *x_re, double *x_im);

typedef struct {
    int nk, nd, nu;
    const double *w_per_hz, *coef_re, *coef_im;
    const int *near_start;
    const double *near_lr, *near_li, *near_er, *near_ei;
} ModalCell;

/* One speed cell's evaluation at shaft speed f [Hz], t in [-1, 1] its place in the cell: x (nk x nu complex).
 * Returns 0, -1 for unusable sizes. */
int cell_sum8(const ModalCell *c, double f, double t, double *x);

#endif
