/*
 * Contacts: connected top imprints (8-connected), split at clear peaks, each paired with its
 * share of the bottom load by a small Gaussian mixture.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* the saddle test's constants (WINDOW_SHARE: internal.h) */
#define SADDLE_RATIO 0.85
#define MIN_PEAK_DISTANCE 2

/*
 * 3 x 3 maximum over the taxels inside a region of the map (rows region[0]..region[1],
 * columns region[2]..region[3], half-open), whose border is taken for the map's (cv2.dilate's
 * border leaves the taxels past it out): the map's own for every taxel whose 3 x 3 is inside.
 */
static void dilate3(const double *src, int cols, const int *region, double *rowmax,
                    double *dst)
{
  int r0 = region[0], r1 = region[1], c0 = region[2], c1 = region[3];
  /* A maximum is exact in any order: rows first, then columns. */
  for (int r = r0; r < r1; r++) {
    const double *s = src + r * cols;
    double *d = rowmax + r * cols;
    for (int c = c0; c < c1; c++) {
      double m = s[c];
      m = c > c0 && s[c - 1] > m ? s[c - 1] : m;
      d[c] = c + 1 < c1 && s[c + 1] > m ? s[c + 1] : m;
    }
  }
  for (int r = r0; r < r1; r++) {
    const double *up = rowmax + (r > r0 ? r - 1 : r) * cols, *mid = rowmax + r * cols;
    const double *down = rowmax + (r + 1 < r1 ? r + 1 : r) * cols;
    for (int c = c0; c < c1; c++) {
      double m = mid[c] > up[c] ? mid[c] : up[c];
      dst[r * cols + c] = down[c] > m ? down[c] : m;
    }
  }
}

/* Give every loaded taxel 8-connected to start (loaded, unlabelled) the label `label`. */
static void flood(const double *top, int rows, int cols, int start, int label, int *labels,
                  int *stack)
{
  int depth = 0;
  labels[start] = label;
  stack[depth++] = start;
  while (depth) {
    int i = stack[--depth], r = i / cols, c = i % cols;
    for (int rr = r - 1; rr <= r + 1; rr++) {
      for (int cc = c - 1; cc <= c + 1; cc++) {
        int j = rr * cols + cc;
        if (rr >= 0 && rr < rows && cc >= 0 && cc < cols && top[j] > 0 && !labels[j]) {
          labels[j] = label;
          stack[depth++] = j;
        }
      }
    }
  }
}

/*
 * Label the 8-connected loaded taxels 1, 2, ... in the raster order of their first taxel
 * (all inside box, k->box's rows and columns).
 */
static int components(const double *top, int rows, int cols, const int *box, int *labels,
                      int *stack)
{
  int count = 0;
  memset(labels, 0, sizeof(int) * rows * cols);
  for (int r = box[0]; r < box[1]; r++) {
    for (int i = r * cols + box[2]; i < r * cols + box[3]; i++) {
      if (top[i] > 0 && !labels[i]) {
        flood(top, rows, cols, i, ++count, labels, stack);
      }
    }
  }
  return count;
}

/*
 * Whether peaks p and q stand apart: the load along the straight line between them,
 * interpolated between taxels, drops below SADDLE_RATIO of the lower one's (contacts._separate).
 */
static int separate(const double *load, const double *values, int rows, int cols, int p, int q)
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
  return lowest < SADDLE_RATIO * (load[p] < load[q] ? load[p] : load[q]);
}

/* Rank among group `label`'s kept peaks of the one nearest to taxel i (the first if tied). */
static int nearest(const int *kept, const int *kept_label, int nkept, int label, int cols, int i)
{
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
  return which;
}

/*
 * Give each clear peak of a connected group its own label; the nearest peak takes a taxel.
 * The peaks are the readings' (top); the saddle between two is judged on the load.
 */
static int split_peaks(sk_kernel *k, const double *top, const double *load, int count)
{
  int rows = k->rows, cols = k->cols, n = k->n;
  const int *box = k->box;
  double *dil = k->scratch, *values = k->scratch + n;
  int *labels = k->labels, *peaks = k->iscratch, *kept = k->iscratch + n;
  int *kept_label = k->iscratch + 2 * n, *groups = k->iscratch + 3 * n;
  /*
   * The box and a taxel around it: the box's taxels get their 3 x 3 maximum, and a path
   * between two peaks (separate) reads the taxel past its end, with a weight of 0.
   */
  int around[4] = {box[0] > 0 ? box[0] - 1 : 0, box[1] < rows ? box[1] + 1 : rows,
                   box[2] > 0 ? box[2] - 1 : 0, box[3] < cols ? box[3] + 1 : cols};
  dilate3(top, cols, around, values, dil);
  int npeaks = 0;
  for (int r = box[0]; r < box[1]; r++) {
    for (int i = r * cols + box[2]; i < r * cols + box[3]; i++) {
      if (top[i] >= dil[i] && top[i] > 0) {
        peaks[npeaks++] = i;
      }
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
  if (dead) {
    dilate3(load, cols, around, values, dil);
  }
  for (int r = around[0]; r < around[1]; r++) {
    for (int i = r * cols + around[2]; i < r * cols + around[3]; i++) {
      values[i] = dead && dead[i] ? dil[i] : load[i];
    }
  }
  int nkept = 0, ngroups = 0, split = 0;
  for (int i = 0; i < npeaks; i++) {
    int p = peaks[i], label = labels[p], apart = 1, seen = 0;
    for (int j = 0; j < nkept && apart; j++) {
      if (kept_label[j] == label) {
        seen = 1;
        apart = separate(load, values, rows, cols, p, kept[j]);
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
    for (int r = box[0]; r < box[1]; r++) {
      for (int i = r * cols + box[2]; i < r * cols + box[3]; i++) {
        if (labels[i] == label) {
          int which = nearest(kept, kept_label, nkept, label, cols, i);
          labels[i] = which == 0 ? label : next + which - 1;
        }
      }
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
static int cut_at_edge(const sk_kernel *k, const sk_found_contact *p, const double *b, double cut,
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

/* Window, centroid and force sums of contact q. */
static void make_contact(sk_kernel *k, int q, sk_found_contact *p)
{
  int rows = k->rows, cols = k->cols, n = k->n;
  const int *box = k->box;
  const double *t = k->tops + q * n, *fraction = k->fractions + q * n;
  const double *bottom = k->counts + n, *force = k->force;
  double *tmp = k->scratch, *b = k->scratch + n;
  double mt = 0.0, sr = 0.0, sc = 0.0, peak = -INFINITY;
  int taxels = 0, r0 = rows, r1 = -1, c0 = cols, c1 = -1;
  /*
   * Past the box both layers read 0: adding those taxels to a sum in raster order changes
   * nothing, so the loops leave them out; b (read in the window, which may reach past the box)
   * and tmp (summed pairwise) are zeroed there, the same arrays as over the whole map.
   */
  memset(b, 0, sizeof(double) * n);
  memset(tmp, 0, sizeof(double) * n);
  for (int r = box[0]; r < box[1]; r++) {
    for (int c = box[2], i = r * cols + c; c < box[3]; c++, i++) {
      b[i] = fraction[i] * bottom[i];
      mt += t[i];
      sr += t[i] * r;
      sc += t[i] * c;
      peak = b[i] > peak ? b[i] : peak;
    }
  }
  if ((box[1] - box[0]) * (box[3] - box[2]) < n) {
    peak = peak > 0.0 ? peak : 0.0; /* the taxels past the box */
  }
  p->row = mt > 0 ? sr / mt : 0.0;
  p->col = mt > 0 ? sc / mt : 0.0;
  p->peak = peak;
  double cut = WINDOW_SHARE * peak;
  for (int r = box[0]; r < box[1]; r++) {
    for (int c = box[2], i = r * cols + c; c < box[3]; c++, i++) {
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

/* Copy contact p's window: counts (top, bottom), then its share of the force maps. */
void sk_contact_window(const sk_kernel *k, int q, double *out)
{
  const sk_found_contact *p = &k->found[q];
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
  int n = k->n, cols = k->cols;
  const int *box = k->box;
  const double *top = k->counts;
  int count = components(top, k->rows, cols, box, k->labels, k->iscratch);
  if (!count) {
    return 0;
  }
  count = split_peaks(k, top, k->force, count);
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
    for (int r = box[0]; r < box[1]; r++) {
      for (int i = r * cols + box[2]; i < r * cols + box[3]; i++) {
        masses[k->labels[i]] += top[i];
      }
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
      memset(t, 0, sizeof(double) * n);
      for (int r = box[0]; r < box[1]; r++) {
        for (int i = r * cols + box[2]; i < r * cols + box[3]; i++) {
          t[i] = top[i] * (k->labels[i] == order[q] ? 1.0 : 0.0);
        }
      }
    }
    sk_share_bottom(k, kn, top + n);
  }
  for (int q = 0; q < kn; q++) {
    make_contact(k, q, &k->found[q]);
  }
  return kn;
}
