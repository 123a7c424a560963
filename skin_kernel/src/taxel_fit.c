/*
 * The taxel_fit shift of one contact's window: each layer's profiles along each axis fitted by
 * Gaussians integrated over the taxel cells (gaussian_cells.c), Gauss-Newton steps solved by
 * solve.c; a saturated layer is refitted in 2-D by censored_fit.c.
 */
#include <math.h>
#include <stddef.h>

#include "internal.h"

/* the profile fits' constants */
#define ITERATIONS 8
#define TOLERANCE 1e-4
#define MIN_EXPLAINED 0.5
#define WIDE 1.5
#define PLATEAU 1e-9
#define STEP_TAXELS 3
#define STEP_SPREAD 0.05
#define STEP_HEIGHT 0.2
#define CUT_WIDTH_SHARE 0.4
/* Cells of the profile (mu, s) over len cells: differences of the CDF at the cell edges. */
static void cells_of(double mu, double s, int len, double *cells)
{
  double before = sk_normal_cdf((-0.5 - mu) / s);
  for (int i = 0; i < len; i++) {
    double after = sk_normal_cdf(((i + 1) - 0.5 - mu) / s);
    cells[i] = after - before;
    before = after;
  }
}

/* Profiles cut by the map's edge (cut_by_edge): a fixed width, start and bounds. */
struct cut {
  int fixed[4];
  double width[4], mu[4], low[4], high[4];
};

/*
 * Fit cell-integrated Gaussians to 4 profiles of nn cells (the first len[j] real); returns 0
 * when a profile has no load, else the centres, widths and explained shares
 * (fit_cell_profiles); ``cut`` (or NULL) holds the widths of cut profiles fixed. scratch:
 * 3 nn doubles.
 */
static int fit_profiles(const double *profiles, int nn, const int *len, const struct cut *cut,
                        double *scratch, double *centre, double *width, double *explained)
{
  double mass[4], mu[4], s[4], amp[4], start[4], start_width[4], low[4], high[4], free[4];
  /* a profile's cells and their derivatives; the misfit's squares take the second's room */
  double *cells = scratch, *d_mu = scratch + nn, *d_s = scratch + 2 * nn, *tmp = d_mu;
  for (int j = 0; j < 4; j++) {
    const double *p = profiles + j * nn;
    mass[j] = sk_sum(p, nn);
    if (!(mass[j] > 0)) {
      return 0;
    }
    double m1 = 0.0, m2 = 0.0;
    for (int i = 0; i < nn; i++) {
      m1 += p[i] * i;
      m2 += p[i] * ((double)i * i);
    }
    mu[j] = m1 / mass[j];
    double var = m2 / mass[j] - mu[j] * mu[j];
    double v = var - 1.0 / 12.0;
    s[j] = sqrt(v < MIN_WIDTH * MIN_WIDTH ? MIN_WIDTH * MIN_WIDTH : v);
    amp[j] = mass[j];
    start[j] = mu[j];
    start_width[j] = s[j];
    /* the centre stays within the cells the profile has */
    low[j] = -0.5;
    high[j] = len[j] - 0.5;
    free[j] = 1.0;
    if (cut && cut->fixed[j]) {
      s[j] = cut->width[j];
      /* a cut profile starts, and falls back, at the given centre, not at its centroid */
      start[j] = mu[j] = cut->mu[j];
      low[j] = cut->low[j];
      high[j] = cut->high[j];
      free[j] = 0.0;
    }
  }
  for (int it = 0; it < ITERATIONS; it++) {
    double step[4][3];
    int solved = 1;
    for (int j = 0; j < 4 && solved; j++) {
      const double *p = profiles + j * nn;
      sk_axis_cells(mu[j], s[j], len[j], cells, d_mu, d_s);
      /*
       * the normal equations' sums in registers (an array in memory made each update wait on
       * the last); symmetric: the lower half mirrors the upper one to the bit. A fixed width
       * has no column: its normal equation is the regulariser's, its step 0.
       */
      double n00 = 0.0, n01 = 0.0, n02 = 0.0, n11 = 0.0, n12 = 0.0, n22 = 0.0;
      double r0 = 0.0, r1 = 0.0, r2 = 0.0;
      for (int i = 0; i < len[j]; i++) {
        double j0 = cells[i], j1 = amp[j] * d_mu[i], j2 = amp[j] * (d_s[i] * free[j]);
        double residual = p[i] - amp[j] * j0;
        n00 += j0 * j0;
        n01 += j0 * j1;
        n02 += j0 * j2;
        r0 += j0 * residual;
        n11 += j1 * j1;
        n12 += j1 * j2;
        r1 += j1 * residual;
        n22 += j2 * j2;
        r2 += j2 * residual;
      }
      double normal[3][3] = {{n00 + 1e-12, n01, n02}, {n01, n11 + 1e-12, n12},
                             {n02, n12, n22 + 1e-12}};
      double rhs[3] = {r0, r1, r2};
      solved = sk_solve(&normal[0][0], rhs, 3);
      for (int a = 0; a < 3; a++) {
        step[j][a] = rhs[a];
      }
    }
    if (!solved) {
      break;
    }
    int small = 1;
    for (int j = 0; j < 4; j++) {
      /* Damped: a step never moves the centre by more than a taxel nor the width by half. */
      amp[j] = amp[j] + step[j][0];
      mu[j] = sk_clip(mu[j] + sk_clip(step[j][1], -1.0, 1.0), low[j], high[j]);
      double w = s[j] + sk_clip(step[j][2], -0.5 * s[j], 0.5 * s[j]);
      s[j] = w < MIN_WIDTH ? MIN_WIDTH : w;
      small &= fabs(step[j][1]) < TOLERANCE;
    }
    if (small) {
      break;
    }
  }
  for (int j = 0; j < 4; j++) {
    const double *p = profiles + j * nn;
    for (int i = 0; i < nn; i++) {
      tmp[i] = p[i] * p[i];
    }
    double energy = sk_sum(tmp, nn);
    cells_of(mu[j], s[j], len[j], cells);
    for (int i = 0; i < nn; i++) {
      double r = p[i] - (i < len[j] ? amp[j] * cells[i] : 0.0);
      tmp[i] = r * r;
    }
    double e = 1.0 - sk_sum(tmp, nn) / (energy > 0 ? energy : 1.0);
    /*
     * A fit that explains little of its profile keeps the centroid it started from; so does a
     * profile a taxel and a half wide, whose centroid has no sampling bias to speak of.
     */
    int keep = isfinite(mu[j]) && e >= MIN_EXPLAINED && (start_width[j] < WIDE || free[j] == 0.0);
    centre[j] = keep ? mu[j] : start[j];
    width[j] = s[j];
    e = isfinite(e) ? e : 0.0;
    explained[j] = e > 0.0 ? e : 0.0;
  }
  return 1;
}

/*
 * Profiles loaded in their first or last cell were cut by the map's edge (the window has an
 * empty cell around its load elsewhere): each takes the width of the same layer's profile along
 * the other axis when that one is whole, and its centre may lie past the edge. Returns whether
 * any was. Rows 0, 1: top and bottom along x; 2, 3 along y.
 */
static int cut_by_edge(const double *profiles, int nn, const int *len, const double *mu,
                       const double *width, struct cut *cut)
{
  int first[4], last[4], any = 0;
  for (int j = 0; j < 4; j++) {
    first[j] = profiles[j * nn] > 0;
    last[j] = profiles[j * nn + len[j] - 1] > 0;
  }
  for (int j = 0; j < 4; j++) {
    int other = (j + 2) % 4;
    cut->fixed[j] = (first[j] || last[j]) && !(first[other] || last[other]);
    any |= cut->fixed[j];
    double reach = PAST_EDGE * width[other];
    cut->low[j] = first[j] ? -0.5 - reach : -0.5;
    cut->high[j] = last[j] ? (len[j] - 0.5) + reach : len[j] - 0.5;
    cut->width[j] = width[other];
    cut->mu[j] = sk_clip(mu[j], cut->low[j], cut->high[j]);
  }
  return any;
}

/*
 * The variance (taxels**2, one axis of the shift) of the centres of the profiles cut by the
 * map's edge: each one's derivative by the width with the mass refitted, times CUT_WIDTH_SHARE
 * of the width. scratch: 3 nn doubles.
 */
static double cut_variance(const double *profiles, int nn, const int *len, const double *mu,
                           const double *width, double *scratch)
{
  double *cell = scratch, *d_mu = scratch + nn, *d_s = scratch + 2 * nn;
  double total = 0.0;
  for (int j = 0; j < 4; j++) {
    const double *p = profiles + j * nn;
    if (!(p[0] > 0 || p[len[j] - 1] > 0)) {
      continue;
    }
    double s = width[j];
    sk_axis_cells(mu[j], s, len[j], cell, d_mu, d_s);
    double n00 = 0.0, n01 = 0.0, n11 = 0.0, b0 = 0.0, b1 = 0.0;
    for (int i = 0; i < len[j]; i++) {
      n00 += cell[i] * cell[i];
      n01 += cell[i] * d_mu[i];
      n11 += d_mu[i] * d_mu[i];
      b0 += cell[i] * d_s[i];
      b1 += d_mu[i] * d_s[i];
    }
    n00 += 1e-12;
    n11 += 1e-12;
    double sens = -(n00 * b1 - n01 * b0) / (n00 * n11 - n01 * n01);
    double v = CUT_WIDTH_SHARE * s * sens;
    total += v * v;
  }
  return 0.5 * total;
}

static int plateau(const double *layer, int m)
{
  double peak = layer[0];
  for (int i = 1; i < m; i++) {
    peak = layer[i] > peak ? layer[i] : peak;
  }
  int at_peak = 0;
  for (int i = 0; i < m; i++) {
    at_peak += layer[i] >= peak * (1.0 - PLATEAU);
  }
  return peak > 0 && at_peak >= 2;
}

/* Taxels on a film's turn-on step at half their force, in place */
static void on_step(double *force, const double *counts, int m)
{
  for (int layer = 0; layer < 2; layer++) {
    const double *c = counts + layer * m;
    double low = INFINITY, peak = 0.0;
    int loaded = 0;
    for (int i = 0; i < m; i++) {
      if (c[i] > 0) {
        loaded++;
        low = c[i] < low ? c[i] : low;
      }
      peak = c[i] > peak ? c[i] : peak;
    }
    int on = 0;
    for (int i = 0; i < m; i++) {
      on += c[i] > 0 && c[i] <= low * (1.0 + STEP_SPREAD);
    }
    if (loaded == 0 || on < STEP_TAXELS || 2 * on > loaded || !(low > STEP_HEIGHT * peak)) {
      continue;
    }
    for (int i = 0; i < m; i++) {
      if (c[i] > 0 && c[i] <= low * (1.0 + STEP_SPREAD)) {
        force[layer * m + i] *= 0.5;
      }
    }
  }
}

void sk_taxel_fit(double *force, const double *counts, const double *censored, int h, int w,
                  double *scratch, double *dx, double *dy, double *confidence,
                  double *cut_var)
{
  int m = h * w, nn = h > w ? h : w;
  on_step(force, counts, m);
  double *profiles = scratch;
  int len[4] = {w, w, h, h};
  for (int layer = 0; layer < 2; layer++) {
    /* A layer flat at its peak hit the end of its force curve: fit it on its counts. */
    const double *maps = plateau(force + layer * m, m) ? counts + layer * m : force + layer * m;
    sk_profiles_of(maps, h, w, nn, profiles + layer * nn, profiles + (2 + layer) * nn);
  }
  double centre[4], width[4], explained[4];
  *cut_var = 0.0;
  if (!fit_profiles(profiles, nn, len, NULL, scratch + 4 * nn, centre, width, explained)) {
    *dx = *dy = *confidence = NAN;
    return;
  }
  struct cut cut;
  double fitted_width[4] = {width[0], width[1], width[2], width[3]};
  if (cut_by_edge(profiles, nn, len, centre, width, &cut)) {
    double again[4], again_width[4], share[4];
    fit_profiles(profiles, nn, len, &cut, scratch + 4 * nn, again, again_width, share);
    for (int j = 0; j < 4; j++) {
      if (cut.fixed[j]) {
        centre[j] = again[j];
        explained[j] = share[j];
        fitted_width[j] = again_width[j];
      }
    }
  }
  *cut_var = cut_variance(profiles, nn, len, centre, fitted_width, scratch + 4 * nn);
  sk_censored_centres(force, censored, h, w, scratch, centre, width);
  *dx = centre[1] - centre[0];
  *dy = centre[3] - centre[2];
  double worst = explained[0];
  for (int j = 1; j < 4; j++) {
    worst = explained[j] < worst ? explained[j] : worst;
  }
  *confidence = worst > 1.0 ? 1.0 : worst;
}
