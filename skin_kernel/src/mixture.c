/*
 * The bottom load shared among several top imprints by a small Gaussian mixture whose centres
 * start at each top centroid plus the common shift of the whole maps, so that neighbouring
 * presses keep their own bottom imprints even when those overlap.
 */
#include <math.h>
#include <string.h>

#include "internal.h"

/* EM steps of the mixture */
#define MIXTURE_ITERATIONS 3

/* Each kept top imprint's share (0..1) of every loaded bottom taxel (contacts._share_bottom). */
void sk_share_bottom(sk_kernel *k, int kn, const double *bottom)
{
  int n = k->n, cols = k->cols;
  const int *box = k->box; /* past it every map reads 0: the loops leave it out */
  int *loaded = k->iscratch;
  double *bv = k->scratch, *ks = k->scratch + n;
  double *mass = ks, *cr = ks + kn, *cc = ks + 2 * kn, *var = ks + 3 * kn, *lw = ks + 4 * kn;
  double *m = ks + 5 * kn, *logp = ks + 9 * kn, *lv = ks + 10 * kn, *norm = ks + 11 * kn;
  memset(k->fractions, 0, sizeof(double) * kn * n);
  int nl = 0;
  for (int r = box[0]; r < box[1]; r++) {
    for (int i = r * cols + box[2]; i < r * cols + box[3]; i++) {
      if (bottom[i] > 0) {
        bv[nl] = bottom[i];
        loaded[nl++] = i;
      }
    }
  }
  if (!nl) {
    return;
  }
  double mc_r = 0.0, mc_c = 0.0;
  for (int q = 0; q < kn; q++) {
    const double *t = k->tops + q * n;
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    for (int r = box[0]; r < box[1]; r++) {
      for (int c = box[2], i = r * cols + c; c < box[3]; c++, i++) {
        s0 += t[i];
        s1 += t[i] * r;
        s2 += t[i] * c;
        s3 += t[i] * ((double)r * r + (double)c * c);
      }
    }
    mass[q] = s0;
    cr[q] = s1 / s0;
    cc[q] = s2 / s0;
    double spread = 0.5 * (s3 / s0 - (cr[q] * cr[q] + cc[q] * cc[q]));
    var[q] = (spread > 0.0 ? spread : 0.0) + 1.0;
    mc_r += s0 * cr[q];
    mc_c += s0 * cc[q];
  }
  double msum = sk_sum(mass, kn), bsum = sk_sum(bv, nl), br = 0.0, bc = 0.0;
  for (int j = 0; j < nl; j++) {
    br += bv[j] * (double)(loaded[j] / cols);
    bc += bv[j] * (double)(loaded[j] % cols);
  }
  /*
   * Presses of one hand or tool mostly share their tangential direction: every bottom imprint
   * starts where the common shift of the whole maps puts it, a taxel wider than its top.
   */
  double common_r = br / bsum - mc_r / msum, common_c = bc / bsum - mc_c / msum;
  for (int q = 0; q < kn; q++) {
    cr[q] += common_r;
    cc[q] += common_c;
    lw[q] = log(mass[q] / msum);
  }
  for (int it = 0; it < MIXTURE_ITERATIONS; it++) {
    memset(m, 0, sizeof(double) * 4 * kn);
    for (int q = 0; q < kn; q++) {
      /* per centre: its log weight less the log of its variance, and its squared norm */
      lv[q] = lw[q] - log(var[q]);
      norm[q] = cr[q] * cr[q] + cc[q] * cc[q];
    }
    for (int j = 0; j < nl; j++) {
      double r = loaded[j] / cols, c = loaded[j] % cols, pos2 = r * r + c * c, top = -INFINITY;
      for (int q = 0; q < kn; q++) {
        double d2 = pos2 - 2.0 * (cr[q] * r + cc[q] * c) + norm[q];
        logp[q] = lv[q] - 0.5 * d2 / var[q];
        top = logp[q] > top ? logp[q] : top;
      }
      double total = 0.0;
      for (int q = 0; q < kn; q++) {
        /* the likeliest centre's term is exp(0) = 1 exactly: no call needed */
        logp[q] = logp[q] == top ? 1.0 : exp(logp[q] - top);
        total += logp[q];
      }
      for (int q = 0; q < kn; q++) {
        double resp = logp[q] / total, w = resp * bv[j];
        k->fractions[q * n + loaded[j]] = resp;
        m[4 * q] += w;
        m[4 * q + 1] += w * r;
        m[4 * q + 2] += w * c;
        m[4 * q + 3] += w * pos2;
      }
    }
    int starved = 0;
    for (int q = 0; q < kn; q++) {
      starved |= !(m[4 * q] > 1e-12 * bsum);
      logp[q] = m[4 * q];
    }
    if (starved) {
      break;
    }
    double gsum = sk_sum(logp, kn);
    for (int q = 0; q < kn; q++) {
      double got = m[4 * q];
      cr[q] = m[4 * q + 1] / got;
      cc[q] = m[4 * q + 2] / got;
      double v = 0.5 * (m[4 * q + 3] / got - (cr[q] * cr[q] + cc[q] * cc[q]));
      var[q] = v > 0.25 ? v : 0.25;
      lw[q] = log(got / gsum);
    }
  }
}
