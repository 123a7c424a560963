/*
 * A Gaussian integrated over unit taxel cells: its share of each cell, and the derivatives by
 * its centre and width, from the normal CDF at the cells' edges. The 1-D profile fits of
 * taxel_fit (taxel_fit.c) and the 2-D censored fit (censored_fit.c) are built on it.
 */
#include <math.h>

#include "internal.h"

/* Abramowitz and Stegun 7.1.26: erf to 1.5e-7, far below the counts' noise */
static const double AS_P = 0.3275911;
static const double AS[5] = {0.254829592, -0.284496736, 1.421413741, -1.453152027, 1.061405429};

double sk_normal_cdf_of(double u, double gauss)
{
  double x = fabs(u) * (1.0 / sqrt(2.0));
  double t = 1.0 / (1.0 + AS_P * x);
  double poly = t * (AS[0] + t * (AS[1] + t * (AS[2] + t * (AS[3] + t * AS[4]))));
  double half = 0.5 * poly * gauss;
  /*
   * 1 - half from u = 0 on, else half (half is never -0, so 0 + half is half): exact, and
   * without a branch, so that a loop over edges runs two at a time (sk_axis_cells)
   */
  double above = u >= 0;
  return above + (1.0 - 2.0 * above) * half;
}

double sk_normal_cdf(double u)
{
  double x = fabs(u) * (1.0 / sqrt(2.0));
  return sk_normal_cdf_of(u, exp(-x * x));
}

void sk_axis_cells(double mu, double s, int n, double *g, double *d_mu, double *d_s)
{
  /*
   * Edge by edge in separate passes, each cell's figures as in one: the exp calls apart, the
   * long chains of the CDF's polynomial and the divisions of one edge do not wait on the next
   * edge's call, and run two edges at a time. The arrays hold each edge's u, its Gaussian,
   * then pdf, CDF and u pdf, until the cells are their differences.
   */
  for (int i = 0; i < n; i++) {
    d_s[i] = ((i + 1) - 0.5 - mu) / s;
  }
  for (int i = 0; i < n; i++) {
    d_mu[i] = exp(-0.5 * d_s[i] * d_s[i]);
  }
  for (int i = 0; i < n; i++) {
    double u = d_s[i], gauss = d_mu[i], pdf = gauss * INV_SQRT2PI;
    g[i] = sk_normal_cdf_of(u, gauss);
    d_mu[i] = pdf;
    d_s[i] = u * pdf;
  }
  double u0 = (-0.5 - mu) / s, gauss0 = exp(-0.5 * u0 * u0);
  double pdf0 = gauss0 * INV_SQRT2PI, cdf0 = sk_normal_cdf_of(u0, gauss0), updf0 = u0 * pdf0;
  for (int i = n - 1; i > 0; i--) {
    g[i] = g[i] - g[i - 1];
    d_mu[i] = -(d_mu[i] - d_mu[i - 1]) / s;
    d_s[i] = -(d_s[i] - d_s[i - 1]) / s;
  }
  if (n > 0) {
    g[0] = g[0] - cdf0;
    d_mu[0] = -(d_mu[0] - pdf0) / s;
    d_s[0] = -(d_s[0] - updf0) / s;
  }
}
