/*
 * The kernel's life cycle and the per-scan entry points: conditioning, contacts, each contact's
 * shift and uncertainty, then the contact figures. Python description: pipeline.py.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* pipeline.py's constant: a shift shorter than this many of its sigmas has no direction */
#define MIN_SNR 3.0

int sk_abi_version(void)
{
  return SK_ABI_VERSION;
}

static double *copy_of(const double *src, size_t count)
{
  double *dst = malloc(sizeof(double) * (count ? count : 1));
  if (dst && src) {
    memcpy(dst, src, sizeof(double) * count);
  }
  return dst;
}

void sk_free(sk_kernel *k)
{
  if (!k) {
    return;
  }
  double *arrays[] = {k->baseline, k->threshold, k->noise, k->gain, k->leak_gate, k->live,
                      k->live_count, k->table_force, k->raw, k->counts, k->force, k->tops,
                      k->fractions, k->scratch, k->fit};
  for (size_t i = 0; i < sizeof(arrays) / sizeof(arrays[0]); i++) {
    free(arrays[i]);
  }
  free(k->dead);
  free(k->clipped);
  free(k->pairs);
  free(k->labels);
  free(k->iscratch);
  free(k);
}

sk_kernel *sk_new(const int *ints, const double *reals, const double *baseline,
                  const double *threshold, const double *noise, const double *gain,
                  const unsigned char *dead, const double *tables)
{
  int rows = ints[SK_ROWS], cols = ints[SK_COLS], full_scale = ints[SK_FULL_SCALE];
  if (rows < 1 || cols < 1 || full_scale < 1 || ints[SK_MAX_CONTACTS] < 0
      || rows > 4096 || cols > 4096) {
    return NULL;
  }
  sk_kernel *k = calloc(1, sizeof(sk_kernel));
  if (!k) {
    return NULL;
  }
  int n = rows * cols, line = rows > cols ? rows : cols;
  k->rows = rows;
  k->cols = cols;
  k->n = n;
  k->kmax = ints[SK_MAX_CONTACTS] < n ? ints[SK_MAX_CONTACTS] : n;
  k->method = ints[SK_METHOD];
  k->crosstalk = ints[SK_REMOVE_CROSSTALK];
  k->fill_dead = ints[SK_FILL_DEAD];
  k->full_scale = full_scale;
  k->has_gain = gain != NULL;
  k->tared = ints[SK_TARED];
  memcpy(k->reals, reals, sizeof(k->reals));
  size_t size = (size_t)full_scale + 1, kcap = k->kmax ? k->kmax : 1;
  k->baseline = copy_of(baseline, 2 * n);
  k->threshold = copy_of(threshold, 2 * n);
  k->noise = copy_of(noise, 2 * n);
  k->gain = gain ? copy_of(gain, 2 * n) : NULL;
  k->leak_gate = copy_of(NULL, 2 * n);
  k->dead = malloc(2 * n);
  k->clipped = calloc(2 * n, 1);
  k->live = copy_of(NULL, 2 * n);
  k->live_count = copy_of(NULL, 2 * n);
  k->table_force = copy_of(tables, 2 * size);
  k->raw = copy_of(NULL, 2 * n);
  k->counts = copy_of(NULL, 2 * n);
  k->force = copy_of(NULL, 2 * n);
  k->pairs = calloc(kcap, sizeof(sk_pair));
  k->tops = copy_of(NULL, kcap * n);
  k->fractions = copy_of(NULL, kcap * n);
  k->scratch = copy_of(NULL, 4 * (size_t)n + 16 * kcap + 4 * ((size_t)line + 1));
  size_t shift_scratch = 8 * ((size_t)line + 1);
  if (k->method == SK_POC) {
    shift_scratch += (size_t)sk_poc_scratch(rows, cols);
  } else if (k->method == SK_TAXEL_FIT) {
    /* the window's censored taxels and a 2-D fit's work (taxelfit.c: fit_censored) */
    shift_scratch += 10 * (size_t)n + 4 * ((size_t)line + 1);
  }
  /* a saturated imprint's fill-in: its marked counts (2 windows), then sk_imprint_force's 3 */
  size_t imprint_scratch = 5 * (size_t)n;
  k->fit = copy_of(NULL, 4 * (size_t)n
                   + (shift_scratch > imprint_scratch ? shift_scratch : imprint_scratch));
  k->labels = malloc(sizeof(int) * n);
  k->iscratch = malloc(sizeof(int) * 4 * n);
  if (!k->baseline || !k->threshold || !k->noise || (gain && !k->gain) || !k->leak_gate
      || !k->dead || !k->clipped || !k->live
      || !k->live_count || !k->table_force || !k->raw || !k->counts || !k->force
      || !k->pairs || !k->tops || !k->fractions || !k->scratch || !k->fit || !k->labels
      || !k->iscratch) {
    sk_free(k);
    return NULL;
  }
  memcpy(k->dead, dead, 2 * n);
  sk_live_counts(k);
  sk_leak_gate(k);
  return k;
}

static double finite_or_zero(double v)
{
  return isfinite(v) ? v : 0.0;
}

/* Normal force: the sensed sum (bottom, or the larger one when it is cut) / fill_factor**2. */
static double normal_force(const sk_kernel *k, const sk_pair *p)
{
  double sensed = p->bottom_cut ? (p->top_force >= p->bottom_force ? p->top_force
                                   : p->bottom_force) : p->bottom_force;
  if (sensed <= 0) {
    sensed = p->top_force;
  }
  double fill = k->reals[SK_FILL_FACTOR];
  return sensed * k->reals[SK_FORCE_SCALE] / (fill * fill);
}

/* One contact's record (ContactEstimator.process). */
static void contact(const sk_kernel *k, int q, double *rec)
{
  const sk_pair *p = &k->pairs[q];
  const double *c = k->reals;
  double pitch = c[SK_PITCH], normal = normal_force(k, p);
  double compliance = c[SK_COMPLIANCE];
  double reach = 0.5 * (k->rows < k->cols ? k->rows : k->cols);
  double load = normal - c[SK_ZERO_REF];
  double sx = p->dx * pitch - (c[SK_X_P] + c[SK_SLOPE_X] * load);
  double sy = p->dy * pitch - (c[SK_Y_P] + c[SK_SLOPE_Y] * load);
  double magnitude = hypot(sx, sy);
  double snr = p->sigma > 0 ? magnitude / (p->sigma * pitch) : INFINITY;
  double own = finite_or_zero(p->confidence);
  own = own < 0.0 ? 0.0 : (own > 1.0 ? 1.0 : own);
  double conf = own * (isfinite(snr) ? snr * snr / (snr * snr + MIN_SNR * MIN_SNR) : 1.0);
  int valid = snr >= MIN_SNR && conf >= c[SK_MIN_CONFIDENCE] && c[SK_MIN_SHIFT] <= magnitude
    && hypot(p->dx, p->dy) <= reach;
  memset(rec, 0, sizeof(double) * SK_NREC);
  rec[SK_AZIMUTH_SIGMA] = SK_PI;
  if (valid) {
    double azimuth = atan2(sy, sx), tangential = magnitude / compliance;
    rec[SK_AZIMUTH] = azimuth;
    rec[SK_ALPHA] = atan2(tangential, normal);
    rec[SK_FORCE_X] = tangential * cos(azimuth);
    rec[SK_FORCE_Y] = tangential * sin(azimuth);
    rec[SK_AZIMUTH_SIGMA] = atan2(p->sigma * pitch, magnitude);
  }
  rec[SK_X_M] = p->col * pitch;
  rec[SK_Y_M] = p->row * pitch;
  rec[SK_FORCE_N] = normal;
  rec[SK_AREA_M2] = p->taxels * pitch * pitch;
  rec[SK_SHIFT_X_M] = finite_or_zero(sx);
  rec[SK_SHIFT_Y_M] = finite_or_zero(sy);
  rec[SK_FORCE_Z] = -normal;
  rec[SK_CONFIDENCE] = conf;
  rec[SK_VALID] = valid;
  rec[SK_KEPT] = normal >= c[SK_MIN_FORCE];
  rec[SK_DX] = p->dx;
  rec[SK_DY] = p->dy;
  rec[SK_PAIR] = q;
  rec[SK_CENSORED] = p->censored;
  rec[SK_SIGMA] = p->sigma;
  rec[SK_TOP_FORCE] = p->top_force;
  rec[SK_BOTTOM_FORCE] = p->bottom_force;
  rec[SK_SHIFT_CONFIDENCE] = p->confidence;
}

/* Write the records of the last scan's pairs to out, strongest first; returns their number. */
static int finish(sk_kernel *k, double *out)
{
  int count = k->npairs;
  for (int q = 0; q < count; q++) {
    double *rec = out + q * SK_NREC;
    contact(k, q, rec);
    /* strongest first, a stable insertion */
    for (int j = q; j > 0 && out[(j - 1) * SK_NREC + SK_FORCE_N] < out[j * SK_NREC + SK_FORCE_N];
         j--) {
      double tmp[SK_NREC];
      memcpy(tmp, out + j * SK_NREC, sizeof(tmp));
      memcpy(out + j * SK_NREC, out + (j - 1) * SK_NREC, sizeof(tmp));
      memcpy(out + (j - 1) * SK_NREC, tmp, sizeof(tmp));
    }
  }
  return count;
}

/*
 * Pair p's force sums with their rim loads, each saturated layer's filled in from its rim
 * (censoring.with_censored_sums). marked: p's window counts with the taxels the ADC cut at
 * full scale (censored there), when p->censored; 2 h w doubles of scratch follow it.
 */
static void imprint_forces(sk_kernel *k, sk_pair *p, const double *marked)
{
  double *sums[2] = {&p->top_force, &p->bottom_force};
  int m = p->h * p->w;
  for (int layer = 0; layer < 2; layer++) {
    double rim = k->reals[SK_RIM_TOP + layer];
    if (p->censored >> layer & 1) {
      *sums[layer] = sk_imprint_force(marked + layer * m, k->fit + (2 + layer) * m, p->h, p->w,
                                      k->reals[SK_CENSOR_TOP + layer],
                                      k->reals[SK_SPREAD_TOP + layer],
                                      k->reals[SK_POWER_TOP + layer],
                                      k->reals[SK_ACTIVATION_TOP + layer], rim,
                                      k->fit + 6 * m);
    } else {
      *sums[layer] += fmin(rim, *sums[layer]);
    }
  }
}

/* model_fit's fit of pair p's window (its counts in k->fit), each taxel's load times its
 * sensitivity (the inverse of its gain) where the kernel has gains. */
static void model_refit(sk_kernel *k, sk_pair *p, const double *model, const double *marks,
                        double *start)
{
  int m = p->h * p->w;
  double *sensitivity = NULL;
  if (k->has_gain) {
    sensitivity = malloc(sizeof(double) * 2 * (size_t)m);
    if (!sensitivity) return;
    for (int layer = 0; layer < 2; layer++) {
      for (int r = 0; r < p->h; r++) {
        for (int c = 0; c < p->w; c++) {
          sensitivity[layer * m + r * p->w + c] =
              1.0 / k->gain[layer * k->n + (p->r0 + r) * k->cols + p->c0 + c];
        }
      }
    }
  }
  sk_model_refit(model, k->fit, marks, sensitivity, p->h, p->w, start, &p->dx, &p->dy);
  free(sensitivity);
}

/* One scan of maps known to hold counts (sk_scan, sk_scan_counts). */
static int scan(sk_kernel *k, const double *maps, int every_pair, double *out, int *status)
{
  k->revived = 0;
  k->npairs = 0;
  sk_touch_counts(k, maps);
  sk_force_of(k);
  int count = sk_pair_layers(k);
  k->npairs = count;
  int censored = 0;
  for (int q = 0; q < count; q++) {
    sk_pair *p = &k->pairs[q];
    int m = p->h * p->w;
    sk_pair_window(k, q, k->fit);
    p->censored = 0;
    /* a loaded taxel the ADC cut is censored whatever its tared counts (conditioning.py) */
    int clipped = sk_clipped_window(k, p, k->fit, 0);
    for (int layer = 0; layer < 2; layer++) {
      double censor = k->reals[SK_CENSOR_TOP + layer], peak = 0.0;
      for (int j = 0; j < m; j++) {
        peak = k->fit[layer * m + j] > peak ? k->fit[layer * m + j] : peak;
      }
      if (censor > 0 && (peak >= censor || clipped >> layer & 1)) {
        p->censored |= 1 << layer;
      }
    }
    censored |= p->censored;
    /* the counts with the ADC's cut taxels marked, for the fill-in and the shift's bounds */
    double *marked = k->fit + 4 * m;
    if (p->censored) {
      memcpy(marked, k->fit, sizeof(double) * 2 * m);
      sk_clipped_window(k, p, marked, 1);
    }
    imprint_forces(k, p, marked);
    p->dx = p->dy = p->confidence = 0.0;
    p->sigma = INFINITY;
    p->cut_var = 0.0;
    if (!every_pair && normal_force(k, p) < k->reals[SK_MIN_FORCE]) {
      /* too light to report, and its force is final: its shift is never asked for */
      continue;
    }
    double *scratch = k->fit + 4 * m;
    if (k->method == SK_TAXEL_FIT || k->method == SK_MODEL_FIT) {
      /*
       * saturated taxels: at the curve's censoring counts, or cut by the ADC (pipeline.py);
       * a pair with none is not censored, and its marks are all 0
       */
      double *marks = marked;
      for (int layer = 0; layer < 2; layer++) {
        double censor = k->reals[SK_CENSOR_TOP + layer];
        for (int j = layer * m; j < (layer + 1) * m; j++) {
          marks[j] = p->censored && censor > 0 && marks[j] >= censor ? 1.0 : 0.0;
        }
      }
      /* model_fit: taxel_fit's shift, refitted by the calibration's taxel model if it has one */
      const double *model = k->reals + SK_TAXEL_MODEL;
      int modelled = k->method == SK_MODEL_FIT && model[SK_MODEL_PITCH] > 0;
      double start[8];
      if (modelled) {
        sk_model_start(model, k->fit + 2 * m, p->h, p->w, start);
      }
      sk_taxel_fit(k->fit + 2 * m, k->fit, marks, p->h, p->w, scratch + 2 * m, &p->dx, &p->dy,
                   &p->confidence, &p->cut_var);
      if (modelled && isfinite(p->dx) && isfinite(p->dy)) {
        model_refit(k, p, model, marks, start);
      }
    } else if (k->method == SK_POC) {
      sk_poc(k->fit, p->h, p->w, scratch, &p->dx, &p->dy, &p->confidence);
    } else {
      sk_centroid(k->fit, p->h, p->w, scratch, &p->dx, &p->dy, &p->confidence);
    }
    if (!(isfinite(p->dx) && isfinite(p->dy))) {
      p->dx = p->dy = p->confidence = 0.0;
      p->cut_var = 0.0;
    }
    p->sigma = sk_sigma(k, p, k->fit, count == 1);
  }
  status[SK_STATUS_PAIRS] = count;
  status[SK_STATUS_CENSORED] = censored;
  status[SK_STATUS_REVIVED] = k->revived;
  return finish(k, out);
}

int sk_scan(sk_kernel *k, const double *maps, int every_pair, double *out, int *status)
{
  int n2 = 2 * k->n;
  for (int i = 0; i < n2; i++) {
    if (!isfinite(maps[i])) {
      return SK_ERR_NOT_FINITE;
    }
    if (maps[i] < 0) {
      return SK_ERR_NEGATIVE;
    }
  }
  return scan(k, maps, every_pair, out, status);
}

int sk_scan_counts(sk_kernel *k, const uint16_t *maps, int every_pair, double *out, int *status)
{
  /* exact as doubles: the scan is sk_scan's to the bit */
  int n2 = 2 * k->n;
  for (int i = 0; i < n2; i++) {
    k->raw[i] = maps[i];
  }
  return scan(k, k->raw, every_pair, out, status);
}

void sk_dead(const sk_kernel *k, unsigned char *out)
{
  memcpy(out, k->dead, 2 * k->n);
}
