/*
 * The correction of a contact's calibrated shift learned from presses of known direction
 * (skin_driver/core/estimation/calibration/direction.py fits it; skin_kernel.h's sk_direction
 * lists the features). taxel_fit's shift errs by an amount that follows where the imprints sit
 * on the taxel grid and how hard the press is; a linear map of those cheap features, fitted at
 * calibration, takes that part out in a few dozen multiplications a contact.
 */
#include <math.h>

#include "internal.h"

int sk_direction_usable(const sk_direction *d)
{
  if (!(d->force_ref_n > 0) || !isfinite(d->force_ref_n)) {
    return 0;
  }
  for (int j = 0; j < SK_DIRECTION_FEATURES; j++) {
    if (!isfinite(d->weight_x[j]) || !isfinite(d->weight_y[j])) {
      return 0;
    }
  }
  return 1;
}

void sk_direction_correct(const sk_direction *d, double col, double row, double normal_n,
                          double pitch_m, double *sx_m, double *sy_m)
{
  double sx = *sx_m / pitch_m, sy = *sy_m / pitch_m;
  double f[SK_DIRECTION_FEATURES];
  double places[4] = {col, row, col + sx, row + sy};
  f[0] = 1.0;
  for (int h = 1; h <= 2; h++) {
    for (int j = 0; j < 4; j++) {
      double phase = 2.0 * SK_PI * h * places[j];
      f[1 + 8 * (h - 1) + 2 * j] = sin(phase);
      f[2 + 8 * (h - 1) + 2 * j] = cos(phase);
    }
  }
  f[17] = sx;
  f[18] = sy;
  f[19] = normal_n / d->force_ref_n - 1.0;
  double cx = 0.0, cy = 0.0;
  for (int j = 0; j < SK_DIRECTION_FEATURES; j++) {
    cx += d->weight_x[j] * f[j];
    cy += d->weight_y[j] * f[j];
  }
  *sx_m = (sx + cx) * pitch_m;
  *sy_m = (sy + cy) * pitch_m;
}
