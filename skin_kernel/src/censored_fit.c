/*
 * A saturated layer's imprint fitted in 2-D, its saturated taxels lower bounds: the censored
 * fit of taxel_fit.
 */
#include <math.h>
#include <string.h>

#include "internal.h"

/* the 2-D fit's constants */
#define MIN_FREE 8
#define ITERATIONS_2D 30
#define HALVINGS 12
#define SEARCHED 1e-5
#define DECREASE 1e-12
#define PINNED 1e-3
#define TOLERANCE_2D 1e-6

/* Whether a layer's window calls for fit_censored: saturated taxels and enough free ones. */
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

/* A taxel's row of the Jacobian (one entry per parameter), then its residual */
#define JAC_ROW (NPARAM + 1)

/* A fit's cells: each axis's shares of a unit Gaussian and their derivatives by centre and width. */
typedef struct {
  double *gx, *dgx_mu, *dgx_s, *gy, *dgy_mu, *dgy_s;
} cells;

/* cells laid out in 3 (h + w) doubles of buf */
static cells cells_in(double *buf, int h, int w)
{
  cells c = {buf, buf + w, buf + 2 * w, buf + 3 * w, buf + 3 * w + h, buf + 3 * w + 2 * h};
  return c;
}

/* the cells of params, in at */
static void cells_at(const double *params, int h, int w, const cells *at)
{
  sk_axis_cells(params[P_X], params[P_SX], w, at->gx, at->dgx_mu, at->dgx_s);
  sk_axis_cells(params[P_Y], params[P_SY], h, at->gy, at->dgy_mu, at->dgy_s);
}

/*
 * Squared misfit of params, a bound taxel's only below it; the cells
 * of params left in at, for the step that follows from them. sq: h w doubles.
 */
static double censored_cost(const double *force, const double *bound, int h, int w,
                            const double *params, const cells *at, double *sq)
{
  cells_at(params, h, w, at);
  for (int r = 0; r < h; r++) {
    for (int c = 0; c < w; c++) {
      int j = r * w + c;
      double residual = force[j] - params[P_MASS] * (at->gy[r] * at->gx[c]);
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
 * lie past the window's edge by PAST_EDGE widths. out may be params.
 */
static void damped(const double *params, const double *step, int h, int w, double *out)
{
  double reach_x = PAST_EDGE * params[P_SX], reach_y = PAST_EDGE * params[P_SY];
  double wx = params[P_SX] + sk_clip(step[3], -0.5 * params[P_SX], 0.5 * params[P_SX]);
  double wy = params[P_SY] + sk_clip(step[4], -0.5 * params[P_SY], 0.5 * params[P_SY]);
  out[P_MASS] = params[P_MASS] + step[0];
  out[P_X] = sk_clip(params[P_X] + sk_clip(step[1], -1.0, 1.0), -0.5 - reach_x, w - 0.5 + reach_x);
  out[P_Y] = sk_clip(params[P_Y] + sk_clip(step[2], -1.0, 1.0), -0.5 - reach_y, h - 0.5 + reach_y);
  out[P_SX] = wx < MIN_WIDTH ? MIN_WIDTH : wx;
  out[P_SY] = wy < MIN_WIDTH ? MIN_WIDTH : wy;
}

/*
 * The normal equations over n packed taxels, each a row of its 5 Jacobian entries and its
 * residual: normal = jac' jac and rhs = jac' residual, each entry summed in taxel order. The
 * 15 distinct entries and 5 sums in three passes of at most seven sums, each held in a register
 * (a 5 x 5 array in memory made every update wait on the last); the lower triangle mirrors the
 * upper.
 */
static void normal_equations(const double *rows, int n, double normal[5][5], double rhs[5])
{
  double s00 = 0.0, s01 = 0.0, s02 = 0.0, s03 = 0.0, s04 = 0.0, r0 = 0.0;
  for (int k = 0; k < n; k++) {
    const double *v = rows + JAC_ROW * k;
    double x0 = v[0];
    s00 += x0 * x0;
    s01 += x0 * v[1];
    s02 += x0 * v[2];
    s03 += x0 * v[3];
    s04 += x0 * v[4];
    r0 += x0 * v[5];
  }
  double s11 = 0.0, s12 = 0.0, s13 = 0.0, s14 = 0.0, r1 = 0.0, s22 = 0.0, s23 = 0.0;
  for (int k = 0; k < n; k++) {
    const double *v = rows + JAC_ROW * k;
    double x1 = v[1], x2 = v[2];
    s11 += x1 * x1;
    s12 += x1 * x2;
    s13 += x1 * v[3];
    s14 += x1 * v[4];
    r1 += x1 * v[5];
    s22 += x2 * x2;
    s23 += x2 * v[3];
  }
  double s24 = 0.0, r2 = 0.0, s33 = 0.0, s34 = 0.0, r3 = 0.0, s44 = 0.0, r4 = 0.0;
  for (int k = 0; k < n; k++) {
    const double *v = rows + JAC_ROW * k;
    double x2 = v[2], x3 = v[3], x4 = v[4], res = v[5];
    s24 += x2 * x4;
    r2 += x2 * res;
    s33 += x3 * x3;
    s34 += x3 * x4;
    r3 += x3 * res;
    s44 += x4 * x4;
    r4 += x4 * res;
  }
  double upper[5][5] = {{s00, s01, s02, s03, s04},
                        {0.0, s11, s12, s13, s14},
                        {0.0, 0.0, s22, s23, s24},
                        {0.0, 0.0, 0.0, s33, s34},
                        {0.0, 0.0, 0.0, 0.0, s44}};
  for (int a = 0; a < 5; a++) {
    for (int b = 0; b < 5; b++) {
      normal[a][b] = b >= a ? upper[a][b] : upper[b][a];
    }
  }
  rhs[0] = r0;
  rhs[1] = r1;
  rhs[2] = r2;
  rhs[3] = r3;
  rhs[4] = r4;
}

/*
 * Gauss-Newton on censored_cost from params, in place; bound: 1 where
 * a taxel is a lower bound. Returns whether it converged. scratch: 6 (h + w) + 6 h w doubles.
 */
static int gauss_newton(const double *force, const double *bound, int h, int w, double *params,
                        double fitted, int searched, double *scratch)
{
  /* the cells of params and of the trial step: an accepted trial's become params' own */
  cells here = cells_in(scratch, h, w), there = cells_in(scratch + 3 * (h + w), h, w);
  /* the taxels that count, packed: a row of their Jacobian's entries and residual each; the
   * rows' room is the misfit's too, used only after they are */
  double *rows = scratch + 6 * (h + w), *sq = rows;
  double trial[NPARAM], whole[NPARAM];
  double cost = censored_cost(force, bound, h, w, params, &here, sq);
  int cost_known = 1;
  for (int it = 0; it < ITERATIONS_2D; it++) {
    double mass = params[P_MASS];
    const double *gx = here.gx, *dgx_mu = here.dgx_mu, *dgx_s = here.dgx_s;
    const double *gy = here.gy, *dgy_mu = here.dgy_mu, *dgy_s = here.dgy_s;
    /* a width at its floor has no column, as a fixed mass: the centre's step cannot count on it */
    double free_sx = params[P_SX] > MIN_WIDTH ? 1.0 : 0.0;
    double free_sy = params[P_SY] > MIN_WIDTH ? 1.0 : 0.0;
    double normal[5][5], rhs[5], step[5];
    int n = 0;
    for (int r = 0; r < h; r++) {
      for (int c = 0; c < w; c++) {
        int j = r * w + c;
        double model = mass * (gy[r] * gx[c]), *row = rows + JAC_ROW * n;
        row[0] = gy[r] * gx[c] * fitted;
        row[1] = mass * (gy[r] * dgx_mu[c]);
        row[2] = mass * (dgy_mu[r] * gx[c]);
        row[3] = mass * (gy[r] * dgx_s[c]) * free_sx;
        row[4] = mass * (dgy_s[r] * gx[c]) * free_sy;
        row[5] = force[j] - model;
        /* a bound taxel counts only while the model falls below its reading */
        n += !(bound[j] > 0) || model < force[j];
      }
    }
    normal_equations(rows, n, normal, rhs);
    for (int a = 0; a < 5; a++) {
      normal[a][a] += 1e-12;
    }
    if (!sk_solve(&normal[0][0], rhs, NPARAM)) {
      return 0;
    }
    memcpy(step, rhs, sizeof(step));
    /* the centre's move as taken: a bound (past the edge, a width's floor) may hold it */
    damped(params, step, h, w, whole);
    double moves = fmax(fabs(whole[P_X] - params[P_X]), fabs(whole[P_Y] - params[P_Y]));
    if (moves < SEARCHED || !searched) {
      /* near the optimum the misfit is flat to its rounding: Gauss-Newton steps as they are;
       * their misfit is wanted only if a later step is searched */
      memcpy(params, whole, sizeof(whole));
      if (moves < TOLERANCE_2D) {
        return 1;
      }
      cells_at(params, h, w, &here);
      cost_known = 0;
      continue;
    }
    if (!cost_known) {
      cost = censored_cost(force, bound, h, w, params, &here, sq);
      cost_known = 1;
    }
    double trial_cost = cost;
    int lower = 0;
    for (int half = 0; half < HALVINGS && !lower; half++) {
      damped(params, step, h, w, trial);
      trial_cost = censored_cost(force, bound, h, w, trial, &there, sq);
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
    cells taken = there;
    there = here;
    here = taken;
  }
  return 0;
}

/*
 * 2-D cell-integrated Gaussian fitted to one layer's window, its censored taxels lower bounds
 * found = (x, y) centre in, (x, y, mass) out; widths from the
 * marginal fits; a mass > 0 is held fixed, else fitted. Unsettled, the censored taxels within
 * PINNED of their reading are taken as readings and the fit polished. Returns 0 (found
 * untouched) when it does not settle. scratch: 6 (h + w) + 7 h w doubles.
 */
static int fit_censored(const double *force, const double *censored, int h, int w,
                        double *scratch, double *found, double sx, double sy, double given)
{
  int m = h * w;
  double *bound = scratch, *work = scratch + m;
  double fitted = given > 0 ? 0.0 : 1.0;
  double params[NPARAM] = {given, found[0], found[1], sx, sy};
  cells start = cells_in(work, h, w);
  const double *gx = start.gx, *gy = start.gy;
  if (!(given > 0)) {
    cells_at(params, h, w, &start);
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
    cells_at(params, h, w, &start);
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
 * Refit the saturated layers in 2-D: the bottom first, whose mass
 * (fitted, or summed when unsaturated) the top takes.
 */
void sk_censored_centres(const double *force, const double *censored, int h, int w,
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
