/*
 * Conditioning: raw counts to tared touch counts (baseline, crosstalk: crosstalk.c, threshold,
 * the taxels the ADC clipped levelled, dead taxels filled), and touch counts to force through each
 * layer's force table and the gains.
 */
#include <string.h>

#include "internal.h"

/*
 * Unnormalised 3 x 3 box sum with a zero border: three-term row sums, then running column sums
 * that add the entering row and subtract the leaving one (a few additions a taxel).
 */
static void box3(const double *src, int rows, int cols, double *rowsum, double *dst)
{
  for (int r = 0; r < rows; r++) {
    const double *s = src + r * cols;
    double *d = rowsum + r * cols;
    for (int c = 0; c < cols; c++) {
      double left = c > 0 ? s[c - 1] : 0.0;
      double right = c + 1 < cols ? s[c + 1] : 0.0;
      d[c] = left + s[c] + right;
    }
  }
  for (int c = 0; c < cols; c++) {
    /* The running sum starts with the zero row above and row 0. */
    double sum = 0.0 + 0.0;
    sum += rowsum[c];
    for (int r = 0; r < rows; r++) {
      double enter = r + 1 < rows ? rowsum[(r + 1) * cols + c] : 0.0;
      double leave = r > 0 ? rowsum[(r - 1) * cols + c] : 0.0;
      double s0 = sum + enter;
      dst[r * cols + c] = s0;
      sum = s0 - leave;
    }
  }
}

void sk_live_counts(sk_kernel *k)
{
  int n = k->n;
  for (int layer = 0; layer < 2; layer++) {
    int any = 0;
    for (int i = 0; i < n; i++) {
      k->live[layer * n + i] = k->dead[layer * n + i] ? 0.0 : 1.0;
      any |= k->dead[layer * n + i];
    }
    k->any_dead[layer] = any;
    box3(k->live + layer * n, k->rows, k->cols, k->scratch, k->live_count + layer * n);
  }
}

/* Unmark dead taxels that read a touch (they only rest below zero), then fill the dead ones. */
static void dead_taxels(sk_kernel *k)
{
  int n = k->n;
  int changed = 0;
  for (int layer = 0; layer < 2; layer++) {
    if (!k->any_dead[layer]) {
      continue;
    }
    /* the arrays held apart from k: a byte store into dead could be k's otherwise */
    unsigned char *dead = k->dead + layer * n;
    const double *counts = k->counts + layer * n;
    for (int i = 0; i < n; i++) {
      if (dead[i] && counts[i] > 0) {
        dead[i] = 0;
        changed = 1;
      }
    }
  }
  if (changed) {
    k->revived = 1;
    sk_live_counts(k);
  }
  double *masked = k->scratch, *rowsum = k->scratch + n, *total = k->scratch + 2 * n;
  for (int layer = 0; layer < 2; layer++) {
    if (!k->any_dead[layer]) {
      continue;
    }
    double *c = k->counts + layer * n;
    const unsigned char *dead = k->dead + layer * n;
    if (!k->fill_dead) {
      for (int i = 0; i < n; i++) {
        c[i] = dead[i] ? 0.0 : c[i];
      }
      continue;
    }
    const double *live = k->live + layer * n, *count = k->live_count + layer * n;
    for (int i = 0; i < n; i++) {
      masked[i] = c[i] * live[i];
    }
    box3(masked, k->rows, k->cols, rowsum, total);
    for (int i = 0; i < n; i++) {
      if (dead[i]) {
        c[i] = count[i] > 0 ? total[i] / count[i] : 0.0;
      }
    }
  }
}

/*
 * Put the taxels the ADC clipped at their layer's highest tared count: a clipped reading is a
 * lower bound whatever crosstalk was taken off it, and the lines with most load lose most, so a
 * plateau would otherwise come out as a crater.
 */
static void level_clipped(sk_kernel *k)
{
  int n = k->n;
  for (int layer = 0; layer < 2; layer++) {
    double *c = k->counts + layer * n, top = 0.0;
    const unsigned char *clipped = k->clipped + layer * n;
    for (int i = 0; i < n; i++) {
      top = c[i] > top ? c[i] : top;
    }
    for (int i = 0; i < n; i++) {
      if (clipped[i] && c[i] > 0) {
        c[i] = top;
      }
    }
  }
}

/* The rows and columns holding a taxel of either layer whose count is not 0 (k->box). */
static void loaded_box(sk_kernel *k)
{
  int rows = k->rows, cols = k->cols, n = k->n;
  int r0 = rows, r1 = 0, c0 = cols, c1 = 0;
  const double *top = k->counts, *bottom = k->counts + n;
  int *column_loaded = k->iscratch;
  memset(column_loaded, 0, sizeof(int) * cols);
  /* flags first, without a branch per taxel */
  for (int r = 0; r < rows; r++) {
    int any = 0;
    for (int c = 0; c < cols; c++) {
      int loaded = (top[r * cols + c] != 0.0) | (bottom[r * cols + c] != 0.0);
      any |= loaded;
      column_loaded[c] |= loaded;
    }
    if (any) {
      r0 = r < r0 ? r : r0;
      r1 = r + 1;
    }
  }
  for (int c = 0; c < cols; c++) {
    if (column_loaded[c]) {
      c0 = c < c0 ? c : c0;
      c1 = c + 1;
    }
  }
  k->box[0] = r0;
  k->box[1] = r1 > r0 ? r1 : r0;
  k->box[2] = c0;
  k->box[3] = c1 > c0 ? c1 : c0;
}

void sk_touch_counts(sk_kernel *k, const double *maps)
{
  int n2 = 2 * k->n, any_clipped = 0;
  double full = (double)k->full_scale;
  /* the arrays held apart from k: a byte store into clipped could be k's otherwise */
  double *counts = k->counts;
  const double *baseline = k->baseline, *threshold = k->threshold;
  unsigned char *clipped = k->clipped;
  for (int i = 0; i < n2; i++) {
    counts[i] = maps[i] - baseline[i];
    clipped[i] = maps[i] >= full;
    any_clipped |= clipped[i];
  }
  k->any_clipped = any_clipped;
  if (k->crosstalk) {
    sk_remove_crosstalk(k);
  }
  for (int i = 0; i < n2; i++) {
    counts[i] = counts[i] < threshold[i] ? 0.0 : counts[i];
  }
  if (any_clipped) {
    level_clipped(k);
  }
  if (k->any_dead[0] || k->any_dead[1]) {
    dead_taxels(k);
  }
  loaded_box(k);
}

int sk_clipped_window(const sk_kernel *k, const sk_found_contact *p, double *window, int mark)
{
  if (!k->any_clipped) {
    return 0;
  }
  int m = p->h * p->w, layers = 0;
  for (int layer = 0; layer < 2; layer++) {
    const unsigned char *clipped = k->clipped + layer * k->n;
    double *counts = window + layer * m;
    for (int r = 0; r < p->h; r++) {
      for (int c = 0; c < p->w; c++) {
        int j = r * p->w + c;
        if (counts[j] > 0 && clipped[(p->r0 + r) * k->cols + p->c0 + c]) {
          layers |= 1 << layer;
          if (mark) {
            counts[j] = (double)k->full_scale;
          }
        }
      }
    }
  }
  return layers;
}

/*
 * One taxel's force by linear interpolation in its layer's table at every integer count: the
 * slope is the next entry less this one, and 0 past the last count; a count at or below 0 has
 * no force, and a reading the ADC clipped reads the force at full scale.
 */
static double force_at(const double *table, int size, double count, int clipped)
{
  if (!(count > 0.0)) {
    return 0.0;
  }
  double last = (double)(size - 1);
  double x = count < last && !clipped ? count : last;
  int j = (int)x;
  double slope = j + 1 < size ? table[j + 1] - table[j] : 0.0;
  return slope * (x - j) + table[j];
}

void sk_force_in(const sk_kernel *k, const double *counts, const unsigned char *clipped,
                 const int *box, double *force)
{
  int n = k->n, cols = k->cols, size = k->full_scale + 1;
  for (int layer = 0; layer < 2; layer++) {
    const double *table = k->table_force + layer * size;
    const double *c = counts + layer * n;
    const unsigned char *cut = clipped ? clipped + layer * n : NULL;
    double *f = force + layer * n;
    const double *gain = k->has_gain ? k->gain + layer * n : NULL;
    int creeps = k->s.drift.creep_per_decade > 0.0;
    /* a count of 0 (every taxel past the box) has the force 0 */
    for (int i = 0; i < n; i++) {
      f[i] = gain ? 0.0 * gain[i] : 0.0;
    }
    for (int r = box[0]; r < box[1]; r++) {
      for (int i = r * cols + box[2]; i < r * cols + box[3]; i++) {
        double v = force_at(table, size, c[i], cut ? cut[i] : 0);
        f[i] = gain ? v * gain[i] : v;
        if (creeps && k->age[layer * n + i] > 0.0) {
          f[i] /= sk_creep_factor(k, layer * n + i);
        }
      }
    }
  }
}

void sk_force_of(sk_kernel *k)
{
  sk_force_in(k, k->counts, k->clipped, k->box, k->force);
}
