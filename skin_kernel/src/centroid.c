/*
 * A window's profiles (each layer summed along rows and along columns) and the centroid method:
 * the difference of the two imprints' weighted centroids.
 */
#include <math.h>

#include "internal.h"

/* Column profiles (summed over rows, in row order) and row profiles (each row summed). */
void sk_profiles_of(const double *layer, int h, int w, int nn, double *along_x,
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

void sk_centroid(const double *counts, int h, int w, double *scratch, double *dx, double *dy,
                 double *confidence)
{
  int m = h * w, nn = h > w ? h : w;
  double centre[4];
  for (int layer = 0; layer < 2; layer++) {
    double *along_x = scratch, *along_y = scratch + nn;
    sk_profiles_of(counts + layer * m, h, w, nn, along_x, along_y);
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
