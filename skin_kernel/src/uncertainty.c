/*
 * The 1-sigma uncertainty of one axis of a contact's shift, from its own data: the counts'
 * noise through each centroid, a shared bottom load's assignment, the pixel-locking error of a
 * narrow imprint, the map's edge (the shift method's own uncertainty of its cut profiles, else
 * a flat fifth of a taxel) and the calibration.
 */
#include <math.h>

#include "internal.h"

/* the least mass with a centroid (counts), and the flat edge term (taxels) */
#define MIN_MASS_COUNTS 1.0
#define BORDER_SIGMA 0.2

double sk_sigma(const sk_kernel *k, const sk_found_contact *p, const double *window, int alone)
{
  int m = p->h * p->w;
  double total = 0.0;
  for (int layer = 0; layer < 2; layer++) {
    const double *own = window + layer * m;
    const double *noise = k->noise + layer * k->n, *full = k->counts + layer * k->n;
    double mom[5] = {0}, err[5] = {0};
    for (int r = 0; r < p->h; r++) {
      for (int c = 0; c < p->w; c++) {
        int i = (p->r0 + r) * k->cols + p->c0 + c;
        double v = own[r * p->w + c];
        /* Only the taxels over the threshold enter a centroid, with their noise. */
        double e2 = v > 0 ? noise[i] * noise[i] : 0.0;
        if (!alone) {
          /* A contact's share of a layer carries the same share of that layer's noise. */
          double share = full[i] > 0 ? v / full[i] : 0.0;
          e2 *= share * share;
          /* its bottom share is a guess: a Bernoulli variance of each taxel's load */
          if (layer == 1) {
            e2 += full[i] * full[i] * share * (1.0 - share);
          }
        }
        double basis[5] = {1.0, r, c, (double)r * r, (double)c * c};
        for (int b = 0; b < 5; b++) {
          mom[b] += v * basis[b];
          err[b] += e2 * basis[b];
        }
      }
    }
    double mass = mom[0];
    /* A share of a few counts (a far neighbour's tail in the mixture) has no centroid. */
    if (!(mass > MIN_MASS_COUNTS)) {
      return INFINITY;
    }
    for (int axis = 1; axis <= 2; axis++) {
      double centre = mom[axis] / mass;
      double var = mom[axis + 2] / mass - centre * centre;
      var = var > 0.0 ? var : 0.0;
      double spread = (err[axis + 2] - 2.0 * centre * err[axis] + centre * centre * err[0])
        / (mass * mass);
      double excess = var - 1.0 / 12.0;
      double lock = exp(-2.0 * (SK_PI * SK_PI) * (excess > 0.0 ? excess : 0.0)) / SK_PI;
      /* Half of both axes: sigma stands for one axis of the shift. */
      total += 0.5 * ((spread > 0.0 ? spread : 0.0) + 0.5 * lock * lock);
    }
  }
  double flat = BORDER_SIGMA * BORDER_SIGMA;
  if (p->cut_var > 0.0) {
    /*
     * the shift method's own uncertainty of its profiles cut by the edge (taxel_fit.c); a contact
     * sharing the bottom load fits the mixture's share, which the flat rule still bounds
     */
    total += alone || p->cut_var > flat ? p->cut_var : flat;
  } else if (p->at_border) {
    total += flat;
  }
  total += k->s.calibration_var;
  return sqrt(total);
}
