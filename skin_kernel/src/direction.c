/*
 * The correction of a contact's calibrated shift learned from presses of known direction
 * (skin_driver/core/estimation/calibration/direction.py fits it; skin_kernel.h's sk_direction
 * lists the features). taxel_fit places each imprint with a bias that follows where it sits on
 * the taxel grid, so the shift errs by the bottom imprint's bias less the top one's (the bottom
 * imprint is the top one moved by the raw shift, misalignment included), more or less with the
 * load; a linear map of those cheap features, fitted at calibration, takes that part out in a
 * few dozen multiplications a contact. The features are written here only: the calibration
 * fits its map on them through sk_direction_features.
 */
#include <math.h>
#include <stddef.h>

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

/* One contact's features, in sk_direction's order (skin_kernel.h lists them), to f. */
static void features_of(double col, double row, double dx, double dy, double load, double *f)
{
  double top[2] = {col, row}, moved[2] = {dx, dy};
  for (int h = 1; h <= 2; h++) {
    for (int axis = 0; axis < 2; axis++) {
      double a = 2.0 * SK_PI * h * top[axis], b = 2.0 * SK_PI * h * (top[axis] + moved[axis]);
      f[4 * (h - 1) + 2 * axis] = sin(b) - sin(a);
      f[4 * (h - 1) + 2 * axis + 1] = cos(b) - cos(a);
      f[8 + 4 * (h - 1) + 2 * axis] = sin(a);
      f[8 + 4 * (h - 1) + 2 * axis + 1] = cos(a);
    }
  }
  for (int j = 0; j < 4; j++) {
    f[16 + j] = f[j] * load;
  }
}

void sk_direction_features(int n, const double *col, const double *row, const double *dx,
                           const double *dy, const double *normal_n, double force_ref_n,
                           double *out)
{
  for (int i = 0; i < n; i++) {
    features_of(col[i], row[i], dx[i], dy[i], normal_n[i] / force_ref_n - 1.0,
                out + (size_t)i * SK_DIRECTION_FEATURES);
  }
}

void sk_direction_correct(const sk_direction *d, double col, double row, double dx, double dy,
                          double normal_n, double pitch_m, double *sx_m, double *sy_m)
{
  double f[SK_DIRECTION_FEATURES];
  features_of(col, row, dx, dy, normal_n / d->force_ref_n - 1.0, f);
  double cx = 0.0, cy = 0.0;
  for (int j = 0; j < SK_DIRECTION_FEATURES; j++) {
    cx += d->weight_x[j] * f[j];
    cy += d->weight_y[j] * f[j];
  }
  *sx_m += cx * pitch_m;
  *sy_m += cy * pitch_m;
}
