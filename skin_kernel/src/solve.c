/*
 * The kernel's one linear solver, for the small normal equations of its fits: taxel_fit's
 * 3 x 3 profile steps, the censored fit's 5 x 5 and the forward model's Levenberg-Marquardt
 * steps of up to SK_SOLVE_MAX parameters. LU factorisation with partial pivoting, column by
 * column (left-looking: each column takes the updates of the columns before it as one dot
 * product), the multipliers scaled by the pivot's reciprocal, then the two triangular
 * substitutions. The fits' narrow windows make ill-conditioned systems (a width held fixed
 * leaves only the regulariser on its diagonal); partial pivoting keeps them stable.
 */
#include <math.h>

#include "internal.h"

int sk_solve(double *a, double *b, int n)
{
  int piv[SK_SOLVE_MAX];
  if (n < 1 || n > SK_SOLVE_MAX) {
    return 0;
  }
  for (int j = 0; j < n; j++) {
    /* column j: the row swaps so far, then the updates of the columns before it */
    for (int i = 0; i < j; i++) {
      double t = a[i * n + j];
      a[i * n + j] = a[piv[i] * n + j];
      a[piv[i] * n + j] = t;
    }
    for (int i = 1; i < j; i++) {
      double dot = 0.0;
      for (int m = 0; m < i; m++) {
        dot += a[i * n + m] * a[m * n + j];
      }
      a[i * n + j] -= dot;
    }
    for (int i = j; i < n; i++) {
      double dot = 0.0;
      for (int m = 0; m < j; m++) {
        dot += a[i * n + m] * a[m * n + j];
      }
      a[i * n + j] -= dot;
    }
    /* the largest entry on or below the diagonal is the pivot */
    int p = j;
    for (int i = j + 1; i < n; i++) {
      p = fabs(a[i * n + j]) > fabs(a[p * n + j]) ? i : p;
    }
    piv[j] = p;
    if (a[p * n + j] == 0.0) {
      return 0;
    }
    double inv = 1.0 / a[p * n + j];
    for (int m = 0; m <= j; m++) {
      double t = a[j * n + m];
      a[j * n + m] = a[p * n + m];
      a[p * n + m] = t;
    }
    for (int i = j + 1; i < n; i++) {
      a[i * n + j] *= inv;
    }
  }
  /* the right-hand side through the same swaps, then L y = b and U x = y */
  for (int i = 0; i < n; i++) {
    double t = b[i];
    b[i] = b[piv[i]];
    b[piv[i]] = t;
  }
  for (int i = 0; i < n; i++) {
    for (int r = i + 1; r < n; r++) {
      b[r] -= b[i] * a[r * n + i];
    }
  }
  for (int i = n - 1; i >= 0; i--) {
    b[i] /= a[i * n + i];
    for (int r = 0; r < i; r++) {
      b[r] -= b[i] * a[r * n + i];
    }
  }
  return 1;
}
