/*
 * Contacts: connected top imprints (8-connected), split at clear peaks, each paired with its
 * share of the bottom load by a small Gaussian mixture. Python description: contacts.py.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* contacts.py's constants: the saddle test (WINDOW_SHARE: internal.h) */
#define SADDLE_RATIO 0.85
#define MIN_PEAK_DISTANCE 2

/* 3 x 3 maximum over the taxels inside the map (cv2.dilate's border leaves them out). */
static void dilate3(const double *src, int rows, int cols, double *rowmax, double *dst)
{
  /* A maximum is exact in any order: rows first, then columns. */
  for (int r = 0; r < rows; r++) {
    const double *s = src + r * cols;
    double *d = rowmax + r * cols;
    for (int c = 0; c < cols; c++) {
      double m = s[c];
      m = c > 0 && s[c - 1] > m ? s[c - 1] : m;
      d[c] = c + 1 < cols && s[c + 1] > m ? s[c + 1] : m;
    }
  }
  for (int r = 0; r < rows; r++) {
    const double *up = rowmax + (r > 0 ? r - 1 : r) * cols, *mid = rowmax + r * cols;
    const double *down = rowmax + (r + 1 < rows ? r + 1 : r) * cols;
    for (int c = 0; c < cols; c++) {
      double m = mid[c] > up[c] ? mid[c] : up[c];
      dst[r * cols + c] = down[c] > m ? down[c] : m;
    }
  }
}

/* Label the 8-connected loaded taxels 1, 2, ... in the raster order of their first taxel. */
static int components(const double *top, int rows, int cols, int *labels, int *stack)
{
  int n = rows * cols, count = 0;
  memset(labels, 0, sizeof(int) * n);
  for (int start = 0; start < n; start++) {
    if (!(top[start] > 0) || labels[start]) {
      continue;
    }
    labels[start] = ++count;
    int depth = 0;
    stack[depth++] = start;
    while (depth) {
      int i = stack[--depth], r = i / cols, c = i % cols;
      for (int rr = r - 1; rr <= r + 1; rr++) {
        for (int cc = c - 1; cc <= c + 1; cc++) {
          int j = rr * cols + cc;
          if (rr >= 0 && rr < rows && cc >= 0 && cc < cols && top[j] > 0 && !labels[j]) {
            labels[j] = count;
            stack[depth++] = j;
          }
        }
      }
    }
  }
  return count;
}

/*
 * Whether peak p stands apart from the higher peak q: the load along the straight line between
 * them, interpolated between taxels, drops below SADDLE_RATIO of p (contacts._separate).
 */
static int separate(const double *top, const double *values, int rows, int cols, int p, int q)
{
  int pr = p / cols, pc = p % cols, qr = q / cols, qc = q % cols;
  int dr = abs(pr - qr), dc = abs(pc - qc);
  int steps = dr > dc ? dr : dc;
  if (steps < MIN_PEAK_DISTANCE) {
    return 0;
  }
  int num = 4 * steps + 1;
  double step = 1.0 / (num - 1), lowest = INFINITY;
  int rmax = rows - 2 > 0 ? rows - 2 : 0, cmax = cols - 2 > 0 ? cols - 2 : 0;
  for (int i = 0; i < num; i++) {
    /* numpy.linspace's points: i * step, the last exactly 1 */
    double t = i == num - 1 ? 1.0 : i * step + 0.0;
    double r = pr + (qr - pr) * t, c = pc + (qc - pc) * t;
    int r0 = (int)floor(r), c0 = (int)floor(c);
    r0 = r0 < 0 ? 0 : (r0 > rmax ? rmax : r0);
    c0 = c0 < 0 ? 0 : (c0 > cmax ? cmax : c0);
    int r1 = r0 + 1 < rows - 1 ? r0 + 1 : rows - 1, c1 = c0 + 1 < cols - 1 ? c0 + 1 : cols - 1;
    double fr = r - r0, fc = c - c0;
    double v = (1 - fr) * (1 - fc) * values[r0 * cols + c0] + (1 - fr) * fc * values[r0 * cols + c1]
      + fr * (1 - fc) * values[r1 * cols + c0] + fr * fc * values[r1 * cols + c1];
    lowest = v < lowest ? v : lowest;
  }
  return lowest < SADDLE_RATIO * top[p];
}

/* Give each clear peak of a connected group its own label; the nearest peak takes a taxel. */
static int split_peaks(sk_kernel *k, const double *top, int count)
{
  int rows = k->rows, cols = k->cols, n = k->n;
  double *dil = k->scratch, *values = k->scratch + n;
  int *labels = k->labels, *peaks = k->iscratch, *kept = k->iscratch + n;
  int *kept_label = k->iscratch + 2 * n, *groups = k->iscratch + 3 * n;
  dilate3(top, rows, cols, values, dil);
  int npeaks = 0;
  for (int i = 0; i < n; i++) {
    if (top[i] >= dil[i] && top[i] > 0) {
      peaks[npeaks++] = i;
    }
  }
  if (npeaks <= count) {
    return count;
  }
  /* Highest first; equal heights keep the raster order (a stable sort). */
  for (int i = 1; i < npeaks; i++) {
    int v = peaks[i], j = i - 1;
    for (; j >= 0 && top[peaks[j]] < top[v]; j--) {
      peaks[j + 1] = peaks[j];
    }
    peaks[j + 1] = v;
  }
  /* A filled-in dead taxel is no evidence of a dip: the path takes its higher neighbour. */
  const unsigned char *dead = k->any_dead[0] ? k->dead : NULL;
  for (int i = 0; i < n; i++) {
    values[i] = dead && dead[i] ? dil[i] : top[i];
  }
  int nkept = 0, ngroups = 0, split = 0;
  for (int i = 0; i < npeaks; i++) {
    int p = peaks[i], label = labels[p], apart = 1, seen = 0;
    for (int j = 0; j < nkept && apart; j++) {
      if (kept_label[j] == label) {
        seen = 1;
        apart = separate(top, values, rows, cols, p, kept[j]);
      }
    }
    if (!seen) {
      groups[ngroups++] = label;
    }
    if (apart) {
      split |= seen;
      kept_label[nkept] = label;
      kept[nkept++] = p;
    }
  }
  if (!split) {
    return count;
  }
  int next = count + 1;
  for (int g = 0; g < ngroups; g++) {
    int label = groups[g], centres = 0;
    for (int j = 0; j < nkept; j++) {
      centres += kept_label[j] == label;
    }
    if (centres < 2) {
      continue;
    }
    for (int i = 0; i < n; i++) {
      if (labels[i] != label) {
        continue;
      }
      int r = i / cols, c = i % cols, best = -1, which = 0, rank = 0, best_d2 = 0;
      for (int j = 0; j < nkept; j++) {
        if (kept_label[j] != label) {
          continue;
        }
        int dr = r - kept[j] / cols, dc = c - kept[j] % cols, d2 = dr * dr + dc * dc;
        if (best < 0 || d2 < best_d2) {
          best = j;
          best_d2 = d2;
          which = rank;
        }
        rank++;
      }
      labels[i] = which == 0 ? label : next + which - 1;
    }
    next += centres - 1;
  }
  return next - 1;
}

/* First index of the largest of n sums (numpy's argmax). */
static int strongest(const double *sums, int n)
{
  int best = 0;
  for (int i = 1; i < n; i++) {
    best = sums[i] > sums[best] ? i : best;
  }
  return best;
}

/*
 * Whether the strongest row or column of the window's bottom share (b over the cut) is the map's
 * edge line (contacts._cut_at_edge); the line sums in the same order. sums: h + w doubles.
 */
static int cut_at_edge(const sk_kernel *k, const sk_pair *p, const double *b, double cut,
                       double *sums)
{
  double *row_sums = sums, *col_sums = sums + p->h;
  memset(sums, 0, sizeof(double) * (p->h + p->w));
  for (int r = 0; r < p->h; r++) {
    for (int c = 0; c < p->w; c++) {
      int i = (p->r0 + r) * k->cols + p->c0 + c;
      double share = b[i] * (p->peak > 0 && b[i] > cut ? 1.0 : 0.0);
      row_sums[r] += share;
      col_sums[c] += share;
    }
  }
  int row = strongest(row_sums, p->h), col = strongest(col_sums, p->w);
  return (p->r0 == 0 && row == 0) || (p->r0 + p->h == k->rows && row == p->h - 1)
         || (p->c0 == 0 && col == 0) || (p->c0 + p->w == k->cols && col == p->w - 1);
}

/* Window, centroid and force sums of contact q (contacts._pair). */
static void make_pair(sk_kernel *k, int q, sk_pair *p)
{
  int rows = k->rows, cols = k->cols, n = k->n;
  const double *t = k->tops + q * n, *fraction = k->fractions + q * n;
  const double *bottom = k->counts + n, *force = k->force;
  double *tmp = k->scratch, *b = k->scratch + n;
  double mt = 0.0, sr = 0.0, sc = 0.0, peak = -INFINITY;
  int taxels = 0, r0 = rows, r1 = -1, c0 = cols, c1 = -1;
  for (int r = 0, i = 0; r < rows; r++) {
    for (int c = 0; c < cols; c++, i++) {
      b[i] = fraction[i] * bottom[i];
      mt += t[i];
      sr += t[i] * r;
      sc += t[i] * c;
      peak = b[i] > peak ? b[i] : peak;
    }
  }
  p->row = mt > 0 ? sr / mt : 0.0;
  p->col = mt > 0 ? sc / mt : 0.0;
  p->peak = peak;
  double cut = WINDOW_SHARE * peak;
  for (int r = 0, i = 0; r < rows; r++) {
    for (int c = 0; c < cols; c++, i++) {
      int touched = t[i] != 0.0, own = peak > 0 && b[i] > cut;
      taxels += touched;
      if (touched || own) {
        r0 = r < r0 ? r : r0;
        r1 = r > r1 ? r : r1;
        c0 = c < c0 ? c : c0;
        c1 = c > c1 ? c : c1;
      }
      tmp[i] = force[i] * (touched ? 1.0 : 0.0);
    }
  }
  r1++;
  c1++;
  p->at_border = r0 == 0 || c0 == 0 || r1 == rows || c1 == cols;
  p->r0 = r0 > 0 ? r0 - 1 : 0;
  p->c0 = c0 > 0 ? c0 - 1 : 0;
  p->h = (r1 + 1 < rows ? r1 + 1 : rows) - p->r0;
  p->w = (c1 + 1 < cols ? c1 + 1 : cols) - p->c0;
  p->taxels = taxels;
  p->top_force = sk_sum(tmp, n);
  int m = 0;
  for (int r = p->r0; r < p->r0 + p->h; r++) {
    for (int c = p->c0; c < p->c0 + p->w; c++) {
      int i = r * cols + c;
      int own = peak > 0 && b[i] > cut;
      tmp[m++] = fraction[i] * force[n + i] * (own ? 1.0 : 0.0);
    }
  }
  p->bottom_force = sk_sum(tmp, m);
  p->bottom_cut = cut_at_edge(k, p, b, cut, k->scratch + 2 * n);
}

/* Copy pair p's window: counts (top, bottom) then its share of the force maps (_force_window). */
void sk_pair_window(const sk_kernel *k, int q, double *out)
{
  const sk_pair *p = &k->pairs[q];
  int n = k->n, m = p->h * p->w;
  const double *t = k->tops + q * n, *fraction = k->fractions + q * n;
  const double *bottom = k->counts + n;
  double peak = p->peak, cut = WINDOW_SHARE * peak;
  for (int r = 0; r < p->h; r++) {
    for (int c = 0; c < p->w; c++) {
      int i = (p->r0 + r) * k->cols + p->c0 + c, j = r * p->w + c;
      double b = fraction[i] * bottom[i];
      out[j] = t[i];
      out[m + j] = b * (peak > 0 && b > cut ? 1.0 : 0.0);
      for (int layer = 0; layer < 2; layer++) {
        double full = k->counts[layer * n + i];
        double share = full > 0 ? out[layer * m + j] / full : 0.0;
        out[(2 + layer) * m + j] = k->force[layer * n + i] * share;
      }
    }
  }
}

int sk_pair_layers(sk_kernel *k)
{
  int n = k->n;
  const double *top = k->counts;
  int count = components(top, k->rows, k->cols, k->labels, k->iscratch);
  if (!count) {
    return 0;
  }
  count = split_peaks(k, top, count);
  if (k->kmax < 1) {
    return 0;
  }
  int kn;
  if (count == 1) {
    /* One top imprint (the common case): it is the whole top map and takes all the bottom. */
    kn = 1;
    memcpy(k->tops, top, sizeof(double) * n);
    for (int i = 0; i < n; i++) {
      k->fractions[i] = 1.0;
    }
  } else {
    double *masses = k->scratch;
    int *order = k->iscratch;
    memset(masses, 0, sizeof(double) * (count + 1));
    for (int i = 0; i < n; i++) {
      masses[k->labels[i]] += top[i];
    }
    /* The strongest top imprints first (a stable sort); the pipeline orders by force later. */
    kn = 0;
    for (int label = 1; label <= count; label++) {
      if (!(masses[label] > 0)) {
        continue;
      }
      int j = kn++ - 1;
      for (; j >= 0 && masses[order[j]] < masses[label]; j--) {
        order[j + 1] = order[j];
      }
      order[j + 1] = label;
    }
    kn = kn < k->kmax ? kn : k->kmax;
    for (int q = 0; q < kn; q++) {
      double *t = k->tops + q * n;
      for (int i = 0; i < n; i++) {
        t[i] = top[i] * (k->labels[i] == order[q] ? 1.0 : 0.0);
      }
    }
    sk_share_bottom(k, kn, top + n);
  }
  for (int q = 0; q < kn; q++) {
    make_pair(k, q, &k->pairs[q]);
  }
  return kn;
}
