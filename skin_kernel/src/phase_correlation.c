/*
 * Shift by band-limited phase-only correlation (poc): the cross-power spectrum of the window's
 * two layers on the low-frequency bins, and a weighted fit of its phase plane.
 */
#include <math.h>

#include "internal.h"

/* the band (cycles per taxel) and the floor of a weight or determinant */
#define BAND 0.2
#define EPS 1e-12

static int pad_size(int n)
{
  /* the smallest power of two >= 2 n, at least 8 (shift._pad_size) */
  int p = 1;
  while (p < 2 * n) {
    p <<= 1;
  }
  return p < 8 ? 8 : p;
}

/* numpy.remainder: the result takes the divisor's sign. */
static double remainder_of(double a, double b)
{
  double mod = fmod(a, b);
  if (mod != 0.0 && ((b < 0) != (mod < 0))) {
    mod += b;
  }
  return mod;
}

/*
 * The band's frequencies along one axis of a padded size, in numpy.fft's order: the full
 * fftfreq for rows, rfftfreq (non-negative only) for columns. Returns their number.
 */
static int band(int padded, int real_only, double *freq)
{
  int count = 0, half = (padded - 1) / 2 + 1;
  double step = 1.0 / padded;
  int total = real_only ? padded / 2 + 1 : padded;
  for (int k = 0; k < total; k++) {
    int index = real_only || k < half ? k : k - padded;
    double f = index * step;
    if (fabs(f) <= BAND) {
      freq[count++] = f;
    }
  }
  return count;
}

int sk_poc_scratch(int h, int w)
{
  int ph = pad_size(h), pw = pad_size(w), bins = ph * (pw / 2 + 1);
  return ph + pw + 2 * (ph * h + w * pw) + 6 * bins;
}

void sk_poc(const double *maps, int h, int w, double *scratch, double *dx, double *dy,
            double *confidence)
{
  int ph = pad_size(h), pw = pad_size(w);
  double *vb = scratch, *ub = scratch + ph;
  int nv = band(ph, 0, vb), nu = band(pw, 1, ub);
  /* the band's DFT factors e^{-2 pi i v y} (nv x h) and e^{-2 pi i x u} (w x nu) */
  double *ey_c = ub + pw, *ey_s = ey_c + nv * h, *ex_c = ey_s + nv * h, *ex_s = ex_c + w * nu;
  for (int a = 0; a < nv; a++) {
    for (int y = 0; y < h; y++) {
      double t = -2.0 * SK_PI * (vb[a] * y);
      ey_c[a * h + y] = cos(t);
      ey_s[a * h + y] = sin(t);
    }
  }
  for (int x = 0; x < w; x++) {
    for (int b = 0; b < nu; b++) {
      double t = -2.0 * SK_PI * (x * ub[b]);
      ex_c[x * nu + b] = cos(t);
      ex_s[x * nu + b] = sin(t);
    }
  }
  int nb = nv * nu;
  double *cross_re = ex_s + w * nu, *cross_im = cross_re + nb, *weight = cross_im + nb;
  double *bu = weight + nb, *bv = bu + nb, *phase = bv + nb;
  int kept = 0, start_x = -1, start_y = -1;
  for (int a = 0; a < nv; a++) {
    for (int b = 0; b < nu; b++) {
      if (vb[a] == 0.0 && ub[b] == 0.0) {
        continue;
      }
      /* each layer's spectrum at this bin */
      double re[2] = {0.0, 0.0}, im[2] = {0.0, 0.0};
      for (int y = 0; y < h; y++) {
        double cy = ey_c[a * h + y], sy = ey_s[a * h + y];
        for (int x = 0; x < w; x++) {
          double cx = ex_c[x * nu + b], sx = ex_s[x * nu + b];
          double e_re = cy * cx - sy * sx, e_im = cy * sx + sy * cx;
          for (int layer = 0; layer < 2; layer++) {
            double m = maps[layer * h * w + y * w + x];
            re[layer] += m * e_re;
            im[layer] += m * e_im;
          }
        }
      }
      /* cross-power: bottom times the conjugate of top */
      cross_re[kept] = re[1] * re[0] + im[1] * im[0];
      cross_im[kept] = im[1] * re[0] - re[1] * im[0];
      weight[kept] = hypot(cross_re[kept], cross_im[kept]) * (ub[b] > 0 ? 2.0 : 1.0);
      bu[kept] = ub[b];
      bv[kept] = vb[a];
      /* the lowest non-zero frequency on each axis starts the fit */
      if (ub[b] == 1.0 / pw && vb[a] == 0.0) {
        start_x = kept;
      }
      if (ub[b] == 0.0 && vb[a] == 1.0 / ph) {
        start_y = kept;
      }
      kept++;
    }
  }
  *dx = *dy = *confidence = 0.0;
  if (start_x < 0 || start_y < 0) {
    return;
  }
  double scale = -1.0 / (2 * SK_PI);
  double shift_x = atan2(cross_im[start_x], cross_re[start_x]) * pw * scale;
  double shift_y = atan2(cross_im[start_y], cross_re[start_y]) * ph * scale;
  /* weighted normal matrix of the plane's two slopes */
  double total = 0.0, a11 = 0.0, a12 = 0.0, a22 = 0.0;
  for (int j = 0; j < kept; j++) {
    total += weight[j];
    a11 += weight[j] * bu[j] * bu[j];
    a12 += weight[j] * bu[j] * bv[j];
    a22 += weight[j] * bv[j] * bv[j];
  }
  if (total <= EPS) {
    return;
  }
  double det = a11 * a22 - a12 * a12, most = a11 * a22 > EPS ? a11 * a22 : EPS;
  if (det <= 1e-9 * most) {
    return;
  }
  double two_pi = 2.0 * SK_PI;
  for (int j = 0; j < kept; j++) {
    phase[j] = atan2(cross_im[j], cross_re[j]) + SK_PI;
  }
  for (int it = 0; it < 2; it++) {
    /* remove the current estimate so that the residual phase stays far from wrapping */
    double b1 = 0.0, b2 = 0.0;
    for (int j = 0; j < kept; j++) {
      double r = remainder_of(shift_x * (two_pi * bu[j]) + shift_y * (two_pi * bv[j])
                              + phase[j], two_pi) - SK_PI;
      b1 += weight[j] * bu[j] * r;
      b2 += weight[j] * bv[j] * r;
    }
    b1 = -b1 / two_pi;
    b2 = -b2 / two_pi;
    shift_x += (a22 * b1 - a12 * b2) / det;
    shift_y += (a11 * b2 - a12 * b1) / det;
  }
  if (!(isfinite(shift_x) && isfinite(shift_y))) {
    return;
  }
  /* the extra pi turns every phasor around, which leaves the length of their sum unchanged */
  double sum_c = 0.0, sum_s = 0.0;
  for (int j = 0; j < kept; j++) {
    double r = shift_x * (two_pi * bu[j]) + shift_y * (two_pi * bv[j]) + phase[j];
    sum_c += weight[j] * cos(r);
    sum_s += weight[j] * sin(r);
  }
  double coherence = hypot(sum_c, sum_s) / total;
  *dx = shift_x;
  *dy = shift_y;
  *confidence = coherence < 0.0 ? 0.0 : (coherence > 1.0 ? 1.0 : coherence);
}
