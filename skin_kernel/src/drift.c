/*
 * Time in the per-scan estimate: the baseline of untouched taxels follows their slow drift, a
 * touched taxel's baseline follows only the drift its untouched layer shows, and a loaded
 * taxel's force is divided by its creep since it was loaded (skin_kernel.h: sk_drift). The creep
 * law is written here only: the creep calibration fits it through sk_creep.
 *
 * Untouched: no taxel of either layer on its row or its column reads a touch. A press lifts
 * whole lines of a passive matrix (crosstalk), and its rim reads below the threshold: following
 * either into the baseline would eat into the press, so neither is followed. A touched taxel is
 * never followed by its own reading, however long it is held.
 */
#include <math.h>
#include <string.h>

#include "internal.h"

/* Age of a taxel under load: grows 1 s a second while it reads a touch, decays after. */
static void age_taxels(sk_kernel *k, double dt)
{
  double recovery = k->s.drift.recovery_s;
  double decay = recovery > 0.0 ? exp(-dt / recovery) : 0.0;
  double *age = k->age;
  const double *counts = k->counts;
  int n2 = 2 * k->n;
  for (int i = 0; i < n2; i++) {
    age[i] = counts[i] > 0.0 ? age[i] + dt : age[i] * decay;
  }
}

/* The baselines follow untouched taxels' readings, touched ones their layer's mean drift. */
static void track_baselines(sk_kernel *k, const double *maps, double dt)
{
  int rows = k->rows, cols = k->cols, n = k->n;
  double alpha = 1.0 - exp(-dt / k->s.drift.track_s);
  /* rows and columns holding a touch of either layer */
  int *row_touched = k->iscratch, *col_touched = k->iscratch + rows;
  memset(row_touched, 0, sizeof(int) * (size_t)(rows + cols));
  const double *top = k->counts, *bottom = k->counts + n;
  for (int r = k->box[0]; r < k->box[1]; r++) {
    for (int c = k->box[2]; c < k->box[3]; c++) {
      int touched = (top[r * cols + c] > 0.0) | (bottom[r * cols + c] > 0.0);
      row_touched[r] |= touched;
      col_touched[c] |= touched;
    }
  }
  for (int layer = 0; layer < 2; layer++) {
    double *baseline = k->baseline + layer * n;
    const double *tare = k->tare + layer * n, *raw = maps + layer * n;
    double moved = 0.0, drift = 0.0, largest = 0.0;
    int followed = 0;
    for (int r = 0; r < rows; r++) {
      for (int c = 0; c < cols; c++) {
        int i = r * cols + c;
        if (!row_touched[r] && !col_touched[c] && !k->dead[layer * n + i]) {
          double step = alpha * (raw[i] - baseline[i]);
          baseline[i] += step;
          moved += step;
          followed++;
        }
      }
    }
    double shared = followed ? moved / followed : 0.0;
    for (int r = 0; r < rows; r++) {
      for (int c = 0; c < cols; c++) {
        int i = r * cols + c;
        if (row_touched[r] || col_touched[c]) {
          baseline[i] += shared;
        }
        double off = baseline[i] - tare[i];
        drift += off;
        largest = fabs(off) > largest ? fabs(off) : largest;
      }
    }
    k->drift_mean[layer] = drift / n;
    k->drift_max[layer] = largest;
  }
}

void sk_drift_step(sk_kernel *k, const double *maps, double time_s)
{
  double dt = 0.0;
  if (isfinite(time_s)) {
    if (isfinite(k->last_time) && time_s > k->last_time) {
      dt = time_s - k->last_time;
    }
    k->last_time = time_s;
  }
  if (!(dt > 0.0)) {
    return;
  }
  if (k->s.drift.track_s > 0.0) {
    track_baselines(k, maps, dt);
  }
  age_taxels(k, dt);
}

/* The creep law: what a reading has risen to after age_s under load (1 at its arrival). */
double sk_creep_rise(const sk_drift *d, double age_s)
{
  return 1.0 + d->creep_per_decade * log10(1.0 + age_s / d->settle_s);
}

double sk_creep_factor(const sk_kernel *k, int i)
{
  return sk_creep_rise(&k->s.drift, k->age[i]) * k->creep_at_1s;
}

void sk_creep(const sk_drift *drift, int n, const double *age_s, int relative_to_1s,
              double *out)
{
  /* as sk_new takes it for a kernel's scans: a multiplication a loaded taxel */
  double at_1s = relative_to_1s && drift->creep_per_decade > 0
    ? 1.0 / sk_creep_rise(drift, 1.0) : 1.0;
  for (int i = 0; i < n; i++) {
    double age = age_s[i] > 0.0 ? age_s[i] : 0.0;
    out[i] = relative_to_1s ? sk_creep_rise(drift, age) * at_1s : sk_creep_rise(drift, age);
  }
}

double sk_held_s(const sk_kernel *k, const sk_found_contact *p)
{
  double held = 0.0;
  for (int layer = 0; layer < 2; layer++) {
    for (int r = p->r0; r < p->r0 + p->h; r++) {
      for (int c = p->c0; c < p->c0 + p->w; c++) {
        double a = k->age[layer * k->n + r * k->cols + c];
        held = a > held ? a : held;
      }
    }
  }
  return held;
}
