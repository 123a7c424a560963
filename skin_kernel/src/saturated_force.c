/*
 * The force a saturated imprint carries: its censored taxels filled in by a bump fitted to its
 * rim, the bump's spread searched around the calibration's (the force calibration fits the
 * same bump: model/imprint.py, model/forcecurve.py).
 */
#include <math.h>

#include "internal.h"

/* the bump's spread (taxels): the least an imprint fits its own from, and the grid searched
 * around the calibration's (factors) */
#define MIN_FITTED_SPREAD 1.0
#define SPREAD_LOW 0.5
#define SPREAD_HIGH 2.0
#define SPREAD_STEPS 13
#define REFINE_ROUNDS 3

/*
 * A saturated imprint's window (h x w counts and force) and what its bumps share whatever
 * their spread: the squared distance of each taxel from the centroid of counts.
 */
typedef struct {
  const double *counts, *force;
  int m;
  double censor, half_power, activation;
  double *dist2;
} imprint;

/* The squared distances from the window's centroid of counts (imprint.bump); 0 without mass. */
static int centre(imprint *im, int w, double *gather)
{
  const double *counts = im->counts;
  int m = im->m;
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
  for (int j = 0; j < m; j++) {
    double dr = (double)(j / w) - r0, dc = (double)(j % w) - c0;
    im->dist2[j] = dr * dr + dc * dc;
  }
  return 1;
}

/* The unit bump of one spread (imprint.bump); a power of 1 is the number itself, exactly. */
static void bump(const imprint *im, double spread, double *phi)
{
  double s2 = spread * spread, half_power = im->half_power;
  for (int j = 0; j < im->m; j++) {
    double d2 = im->dist2[j] / s2;
    phi[j] = exp(-0.5 * (half_power == 1.0 ? d2 : pow(d2, half_power)));
  }
}

/* The least-squares fit of one spread on the free taxels: 0 without a bump. */
static int fill(const imprint *im, double spread, double *phi, double *misfit, double *height)
{
  const double *counts = im->counts, *force = im->force;
  double censor = im->censor, activation = im->activation;
  bump(im, spread, phi);
  double weight = 0.0, dot = 0.0;
  for (int j = 0; j < im->m; j++) {
    if (counts[j] > 0 && counts[j] < censor) {
      weight += phi[j] * phi[j];
      dot += (force[j] - activation) * phi[j];
    }
  }
  if (!(weight > 0)) {
    return 0;
  }
  double a = dot / weight, sq = 0.0, below = 0.0;
  for (int j = 0; j < im->m; j++) {
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
static int best_spread(const imprint *im, double spread, double *phi, double *best)
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
      if (fill(im, grid[i], phi, &misfit, &height) && (!found || misfit < best_misfit)) {
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
  imprint im = {counts, force, m, censor, 0.5 * power, activation, scratch + 2 * m};
  int fitted = spread > 0 && censor > 0 && any && centre(&im, w, gather);
  if (fitted && spread >= MIN_FITTED_SPREAD) {
    fitted = best_spread(&im, spread, phi, &best);
  }
  /* the best spread's bump again: the same numbers as when it was chosen */
  if (fitted) {
    fitted = fill(&im, best, phi, &misfit, &height);
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
