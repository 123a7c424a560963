/*
 * The force a saturated imprint carries: its censored taxels filled in by a bump fitted to its
 * rim, the bump's spread searched around the calibration's. Python description: imprint.py
 * (censored_force) and forcecurve.py (ForceCurve.with_rim).
 */
#include <math.h>

#include "internal.h"

/* imprint.py's constants */
#define MIN_FITTED_SPREAD 1.0
#define SPREAD_LOW 0.5
#define SPREAD_HIGH 2.0
#define SPREAD_STEPS 13
#define REFINE_ROUNDS 3

/* The unit bump over an h x w window of counts, centred on its centroid (imprint.bump). */
static int bump(const double *counts, int h, int w, double spread, double power, double *gather,
                double *phi)
{
  int m = h * w;
  double mass = sk_sum(counts, m);
  if (!(mass > 0)) {
    return 0;
  }
  for (int j = 0; j < m; j++) {
    gather[j] = (double)(j / w) * counts[j];
  }
  double r0 = sk_sum(gather, m) / mass;
  for (int j = 0; j < m; j++) {
    gather[j] = (double)(j % w) * counts[j];
  }
  double c0 = sk_sum(gather, m) / mass;
  double s2 = spread * spread, half_power = 0.5 * power;
  for (int j = 0; j < m; j++) {
    double dr = (double)(j / w) - r0, dc = (double)(j % w) - c0;
    double d2 = (dr * dr + dc * dc) / s2;
    phi[j] = exp(-0.5 * pow(d2, half_power));
  }
  return 1;
}

/* The least-squares fit of one spread on the free taxels (imprint._fill): 0 without a bump. */
static int fill(const double *counts, const double *force, int h, int w, double censor,
                double spread, double power, double activation, double *gather, double *phi,
                double *misfit, double *height)
{
  int m = h * w;
  if (!bump(counts, h, w, spread, power, gather, phi)) {
    return 0;
  }
  double weight = 0.0, dot = 0.0;
  for (int j = 0; j < m; j++) {
    if (counts[j] > 0 && counts[j] < censor) {
      weight += phi[j] * phi[j];
      dot += (force[j] - activation) * phi[j];
    }
  }
  if (!(weight > 0)) {
    return 0;
  }
  double a = dot / weight, sq = 0.0, below = 0.0;
  for (int j = 0; j < m; j++) {
    if (counts[j] >= censor) {
      /* A bump below a censored taxel's reading contradicts it (a lower bound). */
      double d = a * phi[j] - (force[j] - activation);
      d = d < 0.0 ? d : 0.0;
      below += d * d;
    } else if (counts[j] > 0) {
      double d = (force[j] - activation) - a * phi[j];
      sq += d * d;
    }
  }
  *misfit = sq + below;
  *height = a;
  return 1;
}

/* The spread of the best fill over SPREAD_LOW..HIGH of the calibration's, a grid then finer. */
static int best_spread(const double *counts, const double *force, int h, int w, double censor,
                       double spread, double power, double activation, double *gather,
                       double *phi, double *best)
{
  /* numpy.geomspace: powers of ten at even steps of the logarithm, the ends exact */
  double log_low = log10(SPREAD_LOW), log_high = log10(SPREAD_HIGH);
  double log_step = (log_high - log_low) / (SPREAD_STEPS - 1);
  double grid[SPREAD_STEPS];
  for (int i = 0; i < SPREAD_STEPS; i++) {
    double factor = i == 0 ? SPREAD_LOW : (i == SPREAD_STEPS - 1 ? SPREAD_HIGH
                                           : pow(10.0, i * log_step + log_low));
    grid[i] = spread * factor;
  }
  double step = grid[1] / grid[0], best_misfit = 0.0;
  int size = SPREAD_STEPS, found = 0;
  for (int round = 0; round <= REFINE_ROUNDS; round++) {
    for (int i = 0; i < size; i++) {
      double misfit, height;
      if (fill(counts, force, h, w, censor, grid[i], power, activation, gather, phi, &misfit,
               &height)
          && (!found || misfit < best_misfit)) {
        best_misfit = misfit;
        *best = grid[i];
        found = 1;
      }
    }
    if (!found) {
      return 0;
    }
    step = pow(step, 0.5);
    grid[0] = *best * (1.0 / step);
    grid[1] = *best * step;
    size = 2;
  }
  return 1;
}

double sk_imprint_force(const double *counts, const double *force, int h, int w,
                        double censor, double spread, double power, double activation,
                        double rim, double *scratch)
{
  int m = h * w, any = 0;
  for (int j = 0; j < m && !any; j++) {
    any = counts[j] >= censor;
  }
  double *gather = scratch, *phi = scratch + m, read;
  double best = spread, misfit, height;
  int fitted = spread > 0 && censor > 0 && any;
  if (fitted && spread >= MIN_FITTED_SPREAD) {
    fitted = best_spread(counts, force, h, w, censor, spread, power, activation, gather, phi,
                         &best);
  }
  /* the best spread's bump again: the same numbers as when it was chosen */
  if (fitted) {
    fitted = fill(counts, force, h, w, censor, best, power, activation, gather, phi, &misfit,
                  &height);
  }
  if (!fitted) {
    read = sk_sum(force, m);
  } else {
    int nfree = 0, ncensored = 0;
    for (int j = 0; j < m; j++) {
      if (counts[j] > 0 && counts[j] < censor) {
        gather[nfree++] = force[j];
      }
    }
    double free_sum = sk_sum(gather, nfree);
    for (int j = 0; j < m; j++) {
      if (counts[j] >= censor) {
        double bumped = activation + height * phi[j];
        gather[ncensored++] = force[j] > bumped ? force[j] : bumped;
      }
    }
    read = free_sum + sk_sum(gather, ncensored);
  }
  return read + (rim < read ? rim : read);
}
