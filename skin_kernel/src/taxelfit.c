/*
 * Shift of one contact's window: cell-integrated Gaussian profiles (taxel_fit) or the centroid
 * difference. Python description: taxelfit.py and shift.centroid.
 */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "internal.h"

/* taxelfit.py's constants */
#define ITERATIONS 8
#define TOLERANCE 1e-4
#define MIN_WIDTH 0.25
#define MIN_EXPLAINED 0.5
#define WIDE 1.5
#define PLATEAU 1e-9
#define PAST_EDGE 2.0 /* widths */
#define INV_SQRT2PI 0.3989422804014327
#define MIN_FREE 8
#define ITERATIONS_2D 30
#define HALVINGS 12
#define SEARCHED 1e-5
#define DECREASE 1e-12
#define PINNED 1e-3
#define TOLERANCE_2D 1e-10
/* Abramowitz and Stegun 7.1.26: erf to 1.5e-7, far below the counts' noise */
static const double AS_P = 0.3275911;
static const double AS[5] = {0.254829592, -0.284496736, 1.421413741, -1.453152027, 1.061405429};

static double clip(double x, double lo, double hi)
{
  /* comparisons keep a NaN, as numpy.clip does */
  return x < lo ? lo : (x > hi ? hi : x);
}

static double normal_cdf(double u)
{
  double x = fabs(u) * (1.0 / sqrt(2.0));
  double t = 1.0 / (1.0 + AS_P * x);
  double poly = t * (AS[0] + t * (AS[1] + t * (AS[2] + t * (AS[3] + t * AS[4]))));
  double half = 0.5 * poly * exp(-x * x);
  return u >= 0 ? 1.0 - half : half;
}

/*
 * Solve the 3 x 3 system a x = b as numpy.linalg.solve does with OpenBLAS (dgesv: left-looking
 * LU with partial pivoting, multipliers by the pivot's reciprocal, column-wise substitutions),
 * so that the fit follows the reference's steps to the bit: its narrow windows are ill-conditioned
 * and any other order of operations drifts by up to 1e-4 taxels. Returns 0 for a zero pivot.
 */
static int solve3(double a[3][3], double b[3], double x[3])
{
  int piv[3];
  for (int j = 0; j < 3; j++) {
    for (int i = 0; i < j; i++) {
      double t = a[i][j];
      a[i][j] = a[piv[i]][j];
      a[piv[i]][j] = t;
    }
    for (int i = 1; i < j; i++) {
      double dot = 0.0;
      for (int m = 0; m < i; m++) {
        dot += a[i][m] * a[m][j];
      }
      a[i][j] = a[i][j] - dot;
    }
    for (int i = j; i < 3; i++) {
      double dot = 0.0;
      for (int m = 0; m < j; m++) {
        dot += a[i][m] * a[m][j];
      }
      a[i][j] = a[i][j] + -1.0 * dot;
    }
    int p = j;
    for (int i = j + 1; i < 3; i++) {
      p = fabs(a[i][j]) > fabs(a[p][j]) ? i : p;
    }
    piv[j] = p;
    if (a[p][j] == 0.0) {
      return 0;
    }
    double inv = 1.0 / a[p][j];
    for (int m = 0; m <= j; m++) {
      double t = a[j][m];
      a[j][m] = a[p][m];
      a[p][m] = t;
    }
    for (int i = j + 1; i < 3; i++) {
      a[i][j] *= inv;
    }
  }
  for (int i = 0; i < 3; i++) {
    x[i] = b[i];
  }
  for (int i = 0; i < 3; i++) {
    double t = x[i];
    x[i] = x[piv[i]];
    x[piv[i]] = t;
  }
  for (int i = 0; i < 3; i++) {
    for (int r = i + 1; r < 3; r++) {
      x[r] += -x[i] * a[r][i];
    }
  }
  for (int i = 2; i >= 0; i--) {
    x[i] = x[i] / a[i][i];
    for (int r = 0; r < i; r++) {
      x[r] += -x[i] * a[r][i];
    }
  }
  return 1;
}

/* Cells of the profile (mu, s) over len cells: differences of the CDF at the cell edges. */
static void cells_of(double mu, double s, int len, double *cells)
{
  double before = normal_cdf((-0.5 - mu) / s);
  for (int i = 0; i < len; i++) {
    double after = normal_cdf(((i + 1) - 0.5 - mu) / s);
    cells[i] = after - before;
    before = after;
  }
}

/* Profiles cut by the map's edge (taxelfit._cut_by_edge): a fixed width, start and bounds. */
struct cut {
  int fixed[4];
  double width[4], mu[4], low[4], high[4];
};

/*
 * Fit cell-integrated Gaussians to 4 profiles of nn cells (the first len[j] real); returns 0
 * when a profile has no load, else the centres, widths and explained shares
 * (fit_cell_profiles); ``cut`` (or NULL) holds the widths of cut profiles fixed.
 */
static int fit_profiles(const double *profiles, int nn, const int *len, const struct cut *cut,
                        double *scratch, double *centre, double *width, double *explained)
{
  double mass[4], mu[4], s[4], amp[4], start[4], start_width[4], low[4], high[4], free[4];
  double *cells = scratch, *tmp = scratch + nn;
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
      double u0 = (-0.5 - mu[j]) / s[j];
      double pdf0 = exp(-0.5 * u0 * u0) * INV_SQRT2PI, cdf0 = normal_cdf(u0), updf0 = u0 * pdf0;
      double normal[3][3] = {{0}}, rhs[3] = {0};
      for (int i = 0; i < len[j]; i++) {
        double u1 = ((i + 1) - 0.5 - mu[j]) / s[j];
        double pdf1 = exp(-0.5 * u1 * u1) * INV_SQRT2PI, cdf1 = normal_cdf(u1), updf1 = u1 * pdf1;
        /* a fixed width has no column: its normal equation is the regulariser's, its step 0 */
        double jac[3] = {cdf1 - cdf0, amp[j] * (-(pdf1 - pdf0) / s[j]),
                         amp[j] * (-(updf1 - updf0) / s[j] * free[j])};
        double residual = p[i] - amp[j] * jac[0];
        /* symmetric: the lower half mirrors the upper one to the bit */
        for (int a = 0; a < 3; a++) {
          for (int b = a; b < 3; b++) {
            normal[a][b] += jac[a] * jac[b];
          }
          rhs[a] += jac[a] * residual;
        }
        pdf0 = pdf1;
        cdf0 = cdf1;
        updf0 = updf1;
      }
      for (int a = 0; a < 3; a++) {
        normal[a][a] += 1e-12;
        for (int b = 0; b < a; b++) {
          normal[a][b] = normal[b][a];
        }
      }
      solved = solve3(normal, rhs, step[j]);
    }
    if (!solved) {
      break;
    }
    int small = 1;
    for (int j = 0; j < 4; j++) {
      /* Damped: a step never moves the centre by more than a taxel nor the width by half. */
      amp[j] = amp[j] + step[j][0];
      mu[j] = clip(mu[j] + clip(step[j][1], -1.0, 1.0), low[j], high[j]);
      double w = s[j] + clip(step[j][2], -0.5 * s[j], 0.5 * s[j]);
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
 * any was (taxelfit._cut_by_edge). Rows 0, 1: top and bottom along x; 2, 3 along y.
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
    cut->mu[j] = clip(mu[j], cut->low[j], cut->high[j]);
  }
  return any;
}

/* A unit Gaussian's share of each of n cells and its derivatives by mu and s (taxelfit._axis_cells). */
static void axis_cells(double mu, double s, int n, double *g, double *d_mu, double *d_s)
{
  double u0 = (-0.5 - mu) / s;
  double pdf0 = exp(-0.5 * u0 * u0) * INV_SQRT2PI, cdf0 = normal_cdf(u0), updf0 = u0 * pdf0;
  for (int i = 0; i < n; i++) {
    double u1 = ((i + 1) - 0.5 - mu) / s;
    double pdf1 = exp(-0.5 * u1 * u1) * INV_SQRT2PI, cdf1 = normal_cdf(u1), updf1 = u1 * pdf1;
    g[i] = cdf1 - cdf0;
    d_mu[i] = -(pdf1 - pdf0) / s;
    d_s[i] = -(updf1 - updf0) / s;
    pdf0 = pdf1;
    cdf0 = cdf1;
    updf0 = updf1;
  }
}

/* Solve the 5 x 5 system a x = b by elimination with partial pivoting; 0 for a zero pivot. */
static int solve5(double a[5][5], double b[5], double x[5])
{
  for (int j = 0; j < 5; j++) {
    int p = j;
    for (int i = j + 1; i < 5; i++) {
      p = fabs(a[i][j]) > fabs(a[p][j]) ? i : p;
    }
    if (a[p][j] == 0.0) {
      return 0;
    }
    for (int m = 0; m < 5; m++) {
      double t = a[j][m];
      a[j][m] = a[p][m];
      a[p][m] = t;
    }
    double t = b[j];
    b[j] = b[p];
    b[p] = t;
    for (int i = j + 1; i < 5; i++) {
      double f = a[i][j] / a[j][j];
      for (int m = j; m < 5; m++) {
        a[i][m] -= f * a[j][m];
      }
      b[i] -= f * b[j];
    }
  }
  for (int i = 4; i >= 0; i--) {
    double v = b[i];
    for (int m = i + 1; m < 5; m++) {
      v -= a[i][m] * x[m];
    }
    x[i] = v / a[i][i];
  }
  return 1;
}

/* Whether a layer's window calls for fit_censored (taxelfit._fits_censored). */
static int fits_censored(const double *force, const double *censored, int m, int min_free)
{
  int any = 0, free = 0;
  for (int j = 0; j < m; j++) {
    any |= censored[j] > 0;
    free += force[j] > 0 && !(censored[j] > 0);
  }
  return any && free >= min_free;
}

/* Parameters of a 2-D fit: mass, centre x, y, width x, y. */
enum { P_MASS, P_X, P_Y, P_SX, P_SY, NPARAM };

/* Squared misfit of params, a bound taxel's only below it (taxelfit._censored_cost). */
static double censored_cost(const double *force, const double *bound, int h, int w,
                            const double *params, double *scratch)
{
  int nn = h > w ? h : w;
  double *gx = scratch, *gy = gx + w, *dmu = gy + h, *ds = dmu + nn, *sq = ds + nn;
  axis_cells(params[P_X], params[P_SX], w, gx, dmu, ds);
  axis_cells(params[P_Y], params[P_SY], h, gy, dmu, ds);
  for (int r = 0; r < h; r++) {
    for (int c = 0; c < w; c++) {
      int j = r * w + c;
      double residual = force[j] - params[P_MASS] * (gy[r] * gx[c]);
      if (bound[j] > 0 && residual < 0.0) {
        residual = 0.0;
      }
      sq[j] = residual * residual;
    }
  }
  return sk_sum(sq, h * w);
}

/*
 * params moved by step: a taxel at most for a centre, half a width for a width; a centre may
 * lie past the window's edge by PAST_EDGE widths (taxelfit._damped). out may be params.
 */
static void damped(const double *params, const double *step, int h, int w, double *out)
{
  double reach_x = PAST_EDGE * params[P_SX], reach_y = PAST_EDGE * params[P_SY];
  double wx = params[P_SX] + clip(step[3], -0.5 * params[P_SX], 0.5 * params[P_SX]);
  double wy = params[P_SY] + clip(step[4], -0.5 * params[P_SY], 0.5 * params[P_SY]);
  out[P_MASS] = params[P_MASS] + step[0];
  out[P_X] = clip(params[P_X] + clip(step[1], -1.0, 1.0), -0.5 - reach_x, w - 0.5 + reach_x);
  out[P_Y] = clip(params[P_Y] + clip(step[2], -1.0, 1.0), -0.5 - reach_y, h - 0.5 + reach_y);
  out[P_SX] = wx < MIN_WIDTH ? MIN_WIDTH : wx;
  out[P_SY] = wy < MIN_WIDTH ? MIN_WIDTH : wy;
}

/*
 * Gauss-Newton on censored_cost from params, in place (taxelfit._gauss_newton); bound: 1 where
 * a taxel is a lower bound. Returns whether it converged. scratch: 5 max(h, w) + 2 (h + w) +
 * h w doubles.
 */
static int gauss_newton(const double *force, const double *bound, int h, int w, double *params,
                        double fitted, int searched, double *scratch)
{
  double *gx = scratch, *dgx_mu = gx + w, *dgx_s = dgx_mu + w;
  double *gy = dgx_s + w, *dgy_mu = gy + h, *dgy_s = dgy_mu + h;
  double *cost_scratch = dgy_s + h;
  double trial[NPARAM], whole[NPARAM];
  double cost = censored_cost(force, bound, h, w, params, cost_scratch);
  for (int it = 0; it < ITERATIONS_2D; it++) {
    double mass = params[P_MASS];
    axis_cells(params[P_X], params[P_SX], w, gx, dgx_mu, dgx_s);
    axis_cells(params[P_Y], params[P_SY], h, gy, dgy_mu, dgy_s);
    /* a width at its floor has no column, as a fixed mass: the centre's step cannot count on it */
    double free_sx = params[P_SX] > MIN_WIDTH ? 1.0 : 0.0;
    double free_sy = params[P_SY] > MIN_WIDTH ? 1.0 : 0.0;
    double normal[5][5] = {{0}}, rhs[5] = {0}, step[5];
    for (int r = 0; r < h; r++) {
      for (int c = 0; c < w; c++) {
        int j = r * w + c;
        double model = mass * (gy[r] * gx[c]);
        /* a bound taxel counts only while the model falls below its reading */
        if (bound[j] > 0 && !(model < force[j])) {
          continue;
        }
        double jac[5] = {gy[r] * gx[c] * fitted, mass * (gy[r] * dgx_mu[c]),
                         mass * (dgy_mu[r] * gx[c]), mass * (gy[r] * dgx_s[c]) * free_sx,
                         mass * (dgy_s[r] * gx[c]) * free_sy};
        double residual = force[j] - model;
        for (int a = 0; a < 5; a++) {
          for (int b = 0; b < 5; b++) {
            normal[a][b] += jac[a] * jac[b];
          }
          rhs[a] += jac[a] * residual;
        }
      }
    }
    for (int a = 0; a < 5; a++) {
      normal[a][a] += 1e-12;
    }
    if (!solve5(normal, rhs, step)) {
      return 0;
    }
    /* the centre's move as taken: a bound (past the edge, a width's floor) may hold it */
    damped(params, step, h, w, whole);
    double moves = fmax(fabs(whole[P_X] - params[P_X]), fabs(whole[P_Y] - params[P_Y]));
    if (moves < SEARCHED || !searched) {
      /* near the optimum the misfit is flat to its rounding: Gauss-Newton steps as they are */
      memcpy(params, whole, sizeof(whole));
      if (moves < TOLERANCE_2D) {
        return 1;
      }
      cost = censored_cost(force, bound, h, w, params, cost_scratch);
      continue;
    }
    double trial_cost = cost;
    int lower = 0;
    for (int half = 0; half < HALVINGS && !lower; half++) {
      damped(params, step, h, w, trial);
      trial_cost = censored_cost(force, bound, h, w, trial, cost_scratch);
      /* lower by more than its rounding, so that no tie decides where the fit goes */
      lower = trial_cost < cost * (1.0 - DECREASE);
      if (!lower) {
        for (int a = 0; a < 5; a++) {
          step[a] *= 0.5;
        }
      }
    }
    if (!lower) {
      return 0;
    }
    memcpy(params, trial, sizeof(trial));
    cost = trial_cost;
  }
  return 0;
}

/*
 * 2-D cell-integrated Gaussian fitted to one layer's window, its censored taxels lower bounds
 * (taxelfit.fit_censored_layer): found = (x, y) centre in, (x, y, mass) out; widths from the
 * marginal fits; a mass > 0 is held fixed, else fitted. Unsettled, the censored taxels within
 * PINNED of their reading are taken as readings and the fit polished. Returns 0 (found
 * untouched) when it does not settle. scratch: 6 max(h, w) + 2 (h + w) + 2 h w doubles.
 */
static int fit_censored(const double *force, const double *censored, int h, int w,
                        double *scratch, double *found, double sx, double sy, double given)
{
  int m = h * w;
  double *bound = scratch, *work = scratch + m;
  double fitted = given > 0 ? 0.0 : 1.0;
  double params[NPARAM] = {given, found[0], found[1], sx, sy};
  if (!(given > 0)) {
    double *gx = work, *gy = gx + w, *dmu = gy + h, *ds = dmu + (h > w ? h : w);
    axis_cells(found[0], sx, w, gx, dmu, ds);
    axis_cells(found[1], sy, h, gy, dmu, ds);
    double weight = 0.0, along = 0.0;
    for (int r = 0; r < h; r++) {
      for (int c = 0; c < w; c++) {
        if (!(censored[r * w + c] > 0)) {
          double b = gy[r] * gx[c];
          weight += b * b;
          along += force[r * w + c] * b;
        }
      }
    }
    if (!(weight > 0)) {
      return 0;
    }
    params[P_MASS] = along / weight;
  }
  int converged = gauss_newton(force, censored, h, w, params, fitted, 1, work);
  if (!converged) {
    double *gx = work, *gy = gx + w, *dmu = gy + h, *ds = dmu + (h > w ? h : w);
    axis_cells(params[P_X], params[P_SX], w, gx, dmu, ds);
    axis_cells(params[P_Y], params[P_SY], h, gy, dmu, ds);
    for (int r = 0; r < h; r++) {
      for (int c = 0; c < w; c++) {
        int j = r * w + c;
        double model = params[P_MASS] * (gy[r] * gx[c]);
        int pinned = censored[j] > 0 && fabs(force[j] - model) <= PINNED * force[j];
        bound[j] = censored[j] > 0 && !pinned ? 1.0 : 0.0;
      }
    }
    converged = gauss_newton(force, bound, h, w, params, fitted, 0, work);
  }
  if (!(converged && isfinite(params[P_X]) && isfinite(params[P_Y]))) {
    return 0;
  }
  found[0] = params[P_X];
  found[1] = params[P_Y];
  found[2] = params[P_MASS];
  return 1;
}

/*
 * Refit the saturated layers in 2-D (taxelfit._censored_centres): the bottom first, whose mass
 * (fitted, or summed when unsaturated) the top takes.
 */
static void censored_centres(const double *force, const double *censored, int h, int w,
                             double *scratch, double *centre, const double *width)
{
  int m = h * w;
  int saturated = 0;
  for (int j = m; j < 2 * m; j++) {
    saturated |= censored[j] > 0;
  }
  double mass = saturated ? NAN : sk_sum(force + m, m);
  for (int layer = 1; layer >= 0; layer--) {
    /* NaN or none: the mass is fitted */
    double given = layer == 0 ? mass : NAN;
    const double *own = force + layer * m, *marks = censored + layer * m;
    if (!fits_censored(own, marks, m, given > 0 ? 0 : MIN_FREE)) {
      continue;
    }
    double found[3] = {centre[layer], centre[2 + layer], 0.0};
    if (fit_censored(own, marks, h, w, scratch, found, width[layer], width[2 + layer], given)) {
      centre[layer] = found[0];
      centre[2 + layer] = found[1];
      mass = layer == 1 ? found[2] : mass;
    }
  }
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

/* Column profiles (summed over rows, in row order) and row profiles (numpy's pairwise sums). */
static void profiles_of(const double *layer, int h, int w, int nn, double *along_x,
                        double *along_y)
{
  for (int i = 0; i < nn; i++) {
    along_x[i] = 0.0;
    along_y[i] = 0.0;
  }
  for (int r = 0; r < h; r++) {
    for (int c = 0; c < w; c++) {
      along_x[c] += layer[r * w + c];
    }
    along_y[r] = sk_sum(layer + r * w, w);
  }
}

void sk_taxel_fit(const double *force, const double *counts, const double *censored, int h,
                  int w, double *scratch, double *dx, double *dy, double *confidence)
{
  int m = h * w, nn = h > w ? h : w;
  double *profiles = scratch;
  int len[4] = {w, w, h, h};
  for (int layer = 0; layer < 2; layer++) {
    /* A layer flat at its peak hit the end of its force curve: fit it on its counts. */
    const double *maps = plateau(force + layer * m, m) ? counts + layer * m : force + layer * m;
    profiles_of(maps, h, w, nn, profiles + layer * nn, profiles + (2 + layer) * nn);
  }
  double centre[4], width[4], explained[4];
  if (!fit_profiles(profiles, nn, len, NULL, scratch + 4 * nn, centre, width, explained)) {
    *dx = *dy = *confidence = NAN;
    return;
  }
  struct cut cut;
  if (cut_by_edge(profiles, nn, len, centre, width, &cut)) {
    double again[4], again_width[4], share[4];
    fit_profiles(profiles, nn, len, &cut, scratch + 4 * nn, again, again_width, share);
    for (int j = 0; j < 4; j++) {
      if (cut.fixed[j]) {
        centre[j] = again[j];
        explained[j] = share[j];
      }
    }
  }
  censored_centres(force, censored, h, w, scratch, centre, width);
  *dx = centre[1] - centre[0];
  *dy = centre[3] - centre[2];
  double worst = explained[0];
  for (int j = 1; j < 4; j++) {
    worst = explained[j] < worst ? explained[j] : worst;
  }
  *confidence = worst > 1.0 ? 1.0 : worst;
}

void sk_centroid(const double *counts, int h, int w, double *scratch, double *dx, double *dy,
                 double *confidence)
{
  int m = h * w, nn = h > w ? h : w;
  double centre[4];
  for (int layer = 0; layer < 2; layer++) {
    double *along_x = scratch, *along_y = scratch + nn;
    profiles_of(counts + layer * m, h, w, nn, along_x, along_y);
    double mass = sk_sum(along_x, w), sx = 0.0, sy = 0.0;
    if (!(mass > 0)) {
      *dx = *dy = *confidence = NAN;
      return;
    }
    for (int c = 0; c < w; c++) {
      sx += along_x[c] * c;
    }
    for (int r = 0; r < h; r++) {
      sy += along_y[r] * r;
    }
    centre[layer] = sx / mass;
    centre[2 + layer] = sy / mass;
  }
  *dx = centre[1] - centre[0];
  *dy = centre[3] - centre[2];
  *confidence = 1.0;
}
