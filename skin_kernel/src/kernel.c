/*
 * The kernel's life cycle and the per-scan entry points: conditioning, contacts, each contact's
 * shift and uncertainty, then the contact figures.
 */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* a shift shorter than this many of its sigmas has no direction */
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
  double *arrays[] = {k->baseline, k->threshold, k->noise, k->gain, k->crosstalk_gate, k->live,
                      k->live_count, k->table_force, k->raw, k->counts, k->force, k->line_share, k->tops,
                      k->fractions, k->scratch, k->fit, k->tare, k->age};
  for (size_t i = 0; i < sizeof(arrays) / sizeof(arrays[0]); i++) {
    free(arrays[i]);
  }
  free(k->dead);
  free(k->clipped);
  free(k->found);
  free(k->labels);
  free(k->iscratch);
  free(k);
}

/* The layout the binding compares with its mirrors, field by field. */
#define FIELD(type, name) {#type, #name, offsetof(type, name), sizeof(((type *)0)->name)}
#define SIZE(type) {#type, NULL, 0, sizeof(type)}
static const sk_field layout[] = {
  SIZE(sk_taxel_model),
  FIELD(sk_taxel_model, pitch_m), FIELD(sk_taxel_model, fill_factor),
  FIELD(sk_taxel_model, cover_spread_m), FIELD(sk_taxel_model, layer_spread_m),
  FIELD(sk_taxel_model, film_scale), FIELD(sk_taxel_model, film_exponent),
  FIELD(sk_taxel_model, film_ceiling), FIELD(sk_taxel_model, film_activation_n),
  FIELD(sk_taxel_model, turn_on_pa), FIELD(sk_taxel_model, film_step),
  FIELD(sk_taxel_model, full_scale),
  SIZE(sk_curve),
  FIELD(sk_curve, censor_counts), FIELD(sk_curve, rim_load_n), FIELD(sk_curve, spread_taxels),
  FIELD(sk_curve, bump_power), FIELD(sk_curve, activation_n),
  SIZE(sk_settings),
  FIELD(sk_settings, rows), FIELD(sk_settings, cols), FIELD(sk_settings, max_contacts),
  FIELD(sk_settings, method), FIELD(sk_settings, remove_crosstalk),
  FIELD(sk_settings, fill_dead), FIELD(sk_settings, full_scale), FIELD(sk_settings, tared),
  FIELD(sk_settings, pitch_m), FIELD(sk_settings, compliance_m_per_n),
  FIELD(sk_settings, min_force_n), FIELD(sk_settings, min_confidence),
  FIELD(sk_settings, min_shift_m), FIELD(sk_settings, force_scale),
  FIELD(sk_settings, fill_factor), FIELD(sk_settings, x_p_m), FIELD(sk_settings, y_p_m),
  FIELD(sk_settings, slope_x_m_per_n), FIELD(sk_settings, slope_y_m_per_n),
  FIELD(sk_settings, zero_ref_n), FIELD(sk_settings, calibration_var),
  FIELD(sk_settings, curves), FIELD(sk_settings, model), FIELD(sk_settings, direction),
  SIZE(sk_direction),
  FIELD(sk_direction, on), FIELD(sk_direction, force_ref_n), FIELD(sk_direction, weight_x),
  FIELD(sk_direction, weight_y),
  FIELD(sk_settings, drift),
  SIZE(sk_drift),
  FIELD(sk_drift, track_s), FIELD(sk_drift, creep_per_decade), FIELD(sk_drift, settle_s),
  FIELD(sk_drift, recovery_s),
  SIZE(sk_contact),
  FIELD(sk_contact, x_m), FIELD(sk_contact, y_m), FIELD(sk_contact, force_n),
  FIELD(sk_contact, area_m2), FIELD(sk_contact, shift_x_m), FIELD(sk_contact, shift_y_m),
  FIELD(sk_contact, azimuth_rad), FIELD(sk_contact, azimuth_sigma_rad),
  FIELD(sk_contact, alpha_rad), FIELD(sk_contact, force_x_n), FIELD(sk_contact, force_y_n),
  FIELD(sk_contact, force_z_n), FIELD(sk_contact, confidence), FIELD(sk_contact, dx),
  FIELD(sk_contact, dy), FIELD(sk_contact, sigma), FIELD(sk_contact, top_force_n),
  FIELD(sk_contact, bottom_force_n), FIELD(sk_contact, shift_confidence),
  FIELD(sk_contact, valid), FIELD(sk_contact, kept), FIELD(sk_contact, index),
  FIELD(sk_contact, censored), FIELD(sk_contact, held_s),
  SIZE(sk_status),
  FIELD(sk_status, found), FIELD(sk_status, censored), FIELD(sk_status, revived),
  FIELD(sk_status, drift_mean), FIELD(sk_status, drift_max),
};

int sk_layout(const sk_field **fields, int *abi_version)
{
  *fields = layout;
  *abi_version = SK_ABI_VERSION;
  return (int)(sizeof(layout) / sizeof(layout[0]));
}

/* The first setting sk_new cannot use, said in message; SK_OK when there is none. */
static int refuse(const sk_settings *s, unsigned long settings_size, char *message,
                  unsigned long size)
{
  char text[160];
  text[0] = '\0';
  if (settings_size != sizeof(sk_settings)) {
    snprintf(text, sizeof text, "settings of %lu bytes, this library's are %lu (ABI %d)",
             settings_size, (unsigned long)sizeof(sk_settings), SK_ABI_VERSION);
  } else if (s->rows < 1 || s->cols < 1 || s->rows > 4096 || s->cols > 4096) {
    snprintf(text, sizeof text, "maps of %d x %d taxels (1 to 4096 each)", s->rows, s->cols);
  } else if (s->full_scale < 1) {
    snprintf(text, sizeof text, "full scale %d counts (1 or more)", s->full_scale);
  } else if (s->max_contacts < 0) {
    snprintf(text, sizeof text, "max_contacts %d (0 or more)", s->max_contacts);
  } else if (s->method < 0 || s->method >= SK_NMETHODS) {
    snprintf(text, sizeof text, "unknown shift method %d (0 to %d)", s->method,
             SK_NMETHODS - 1);
  } else if (!(s->pitch_m > 0) || !(s->fill_factor > 0) || !(s->compliance_m_per_n > 0)) {
    snprintf(text, sizeof text, "pitch, fill factor and compliance must be positive");
  } else if (s->direction.on && !sk_direction_usable(&s->direction)) {
    snprintf(text, sizeof text, "the direction correction needs a positive reference force "
             "and finite weights");
  } else if (!(s->drift.track_s >= 0) || !(s->drift.creep_per_decade >= 0)
             || !isfinite(s->drift.track_s) || !isfinite(s->drift.creep_per_decade)
             || (s->drift.creep_per_decade > 0
                 && !(s->drift.settle_s > 0 && s->drift.recovery_s > 0))) {
    snprintf(text, sizeof text, "drift: track_s and creep_per_decade finite and >= 0, "
             "settle_s and recovery_s positive with creep");
  } else {
    return SK_OK;
  }
  if (message && size) {
    snprintf(message, size, "%s", text);
  }
  return SK_ERR_SETTINGS;
}

int sk_new(const sk_settings *settings, unsigned long settings_size, const double *baseline,
           const double *threshold, const double *noise, const double *gain,
           const unsigned char *dead, const double *tables, sk_kernel **out, char *message,
           unsigned long message_size)
{
  *out = NULL;
  if (message && message_size) {
    message[0] = '\0';
  }
  int refused = refuse(settings, settings_size, message, message_size);
  if (refused != SK_OK) {
    return refused;
  }
  const sk_settings *s = settings;
  int rows = s->rows, cols = s->cols, full_scale = s->full_scale;
  sk_kernel *k = calloc(1, sizeof(sk_kernel));
  if (!k) {
    return SK_ERR_NO_MEMORY;
  }
  k->s = *s;
  int n = rows * cols, line = rows > cols ? rows : cols;
  k->rows = rows;
  k->cols = cols;
  k->n = n;
  k->kmax = s->max_contacts < n ? s->max_contacts : n;
  k->method = s->method;
  k->crosstalk = s->remove_crosstalk != 0;
  k->fill_dead = s->fill_dead != 0;
  k->full_scale = full_scale;
  k->has_gain = gain != NULL;
  k->tared = s->tared != 0;
  size_t size = (size_t)full_scale + 1, kcap = k->kmax ? k->kmax : 1;
  k->baseline = copy_of(baseline, 2 * n);
  k->threshold = copy_of(threshold, 2 * n);
  k->noise = copy_of(noise, 2 * n);
  k->gain = gain ? copy_of(gain, 2 * n) : NULL;
  k->crosstalk_gate = copy_of(NULL, 2 * n);
  k->dead = malloc(2 * n);
  k->clipped = calloc(2 * n, 1);
  k->live = copy_of(NULL, 2 * n);
  k->live_count = copy_of(NULL, 2 * n);
  k->table_force = copy_of(tables, 2 * size);
  k->raw = copy_of(NULL, 2 * n);
  k->counts = copy_of(NULL, 2 * n);
  k->force = copy_of(NULL, 2 * n);
  k->line_share = copy_of(NULL, 2 * ((size_t)rows + cols));
  k->found = calloc(kcap, sizeof(sk_found_contact));
  k->tops = copy_of(NULL, kcap * n);
  k->fractions = copy_of(NULL, kcap * n);
  k->scratch = copy_of(NULL, 4 * (size_t)n + 16 * kcap + 4 * ((size_t)line + 1));
  size_t shift_scratch = 8 * ((size_t)line + 1);
  if (k->method == SK_POC) {
    shift_scratch += (size_t)sk_poc_scratch(rows, cols);
  } else if (k->method == SK_TAXEL_FIT || k->method == SK_MODEL_FIT) {
    /* the window's censored taxels and a 2-D fit's work (censored_fit.c: fit_censored);
     * model_fit starts from taxel_fit's shift, so it needs the same */
    shift_scratch += 10 * (size_t)n + 4 * ((size_t)line + 1);
  }
  /* a saturated imprint's fill-in: its marked counts (2 windows), then sk_imprint_force's 3 */
  size_t imprint_scratch = 5 * (size_t)n;
  k->fit = copy_of(NULL, 4 * (size_t)n
                   + (shift_scratch > imprint_scratch ? shift_scratch : imprint_scratch));
  k->tare = copy_of(baseline, 2 * n);
  k->age = calloc(2 * (size_t)n, sizeof(double));
  k->last_time = NAN;
  k->creep_at_1s = s->drift.creep_per_decade > 0 ? 1.0 / sk_creep_rise(&s->drift, 1.0) : 1.0;
  k->labels = malloc(sizeof(int) * n);
  k->iscratch = malloc(sizeof(int) * 4 * n);
  if (!k->baseline || !k->threshold || !k->noise || (gain && !k->gain) || !k->crosstalk_gate
      || !k->dead || !k->clipped || !k->live
      || !k->live_count || !k->table_force || !k->raw || !k->counts || !k->force
      || !k->line_share || !k->found || !k->tops || !k->fractions || !k->scratch || !k->fit || !k->labels
      || !k->iscratch || !k->tare || !k->age) {
    sk_free(k);
    if (message && message_size) {
      snprintf(message, message_size, "no memory for a kernel of %d x %d taxels", rows, cols);
    }
    return SK_ERR_NO_MEMORY;
  }
  memcpy(k->dead, dead, 2 * n);
  sk_live_counts(k);
  sk_crosstalk_gate(k);
  *out = k;
  return SK_OK;
}

static double finite_or_zero(double v)
{
  return isfinite(v) ? v : 0.0;
}

/* Normal force: the sensed sum (bottom, or the larger one when it is cut) / fill_factor**2. */
static double normal_force(const sk_kernel *k, const sk_found_contact *p)
{
  double sensed = p->bottom_cut ? (p->top_force >= p->bottom_force ? p->top_force
                                   : p->bottom_force) : p->bottom_force;
  if (sensed <= 0) {
    sensed = p->top_force;
  }
  double fill = k->s.fill_factor;
  return sensed * k->s.force_scale / (fill * fill);
}

/* One contact's record (ContactEstimator.process). */
static void contact(const sk_kernel *k, int q, sk_contact *rec)
{
  const sk_found_contact *p = &k->found[q];
  const sk_settings *c = &k->s;
  double pitch = c->pitch_m, normal = normal_force(k, p);
  double reach = 0.5 * (k->rows < k->cols ? k->rows : k->cols);
  double load = normal - c->zero_ref_n;
  double sx = p->dx * pitch - (c->x_p_m + c->slope_x_m_per_n * load);
  double sy = p->dy * pitch - (c->y_p_m + c->slope_y_m_per_n * load);
  if (c->direction.on && isfinite(p->sigma)) {
    sk_direction_correct(&c->direction, p->col, p->row, p->dx, p->dy, normal, pitch, &sx, &sy);
  }
  double magnitude = hypot(sx, sy);
  double snr = p->sigma > 0 ? magnitude / (p->sigma * pitch) : INFINITY;
  double own = finite_or_zero(p->confidence);
  own = own < 0.0 ? 0.0 : (own > 1.0 ? 1.0 : own);
  double conf = own * (isfinite(snr) ? snr * snr / (snr * snr + MIN_SNR * MIN_SNR) : 1.0);
  int valid = snr >= MIN_SNR && conf >= c->min_confidence && c->min_shift_m <= magnitude
    && hypot(p->dx, p->dy) <= reach;
  memset(rec, 0, sizeof(*rec));
  rec->azimuth_sigma_rad = SK_PI;
  if (valid) {
    double azimuth = atan2(sy, sx), tangential = magnitude / c->compliance_m_per_n;
    rec->azimuth_rad = azimuth;
    rec->alpha_rad = atan2(tangential, normal);
    rec->force_x_n = tangential * cos(azimuth);
    rec->force_y_n = tangential * sin(azimuth);
    rec->azimuth_sigma_rad = atan2(p->sigma * pitch, magnitude);
  }
  rec->x_m = p->col * pitch;
  rec->y_m = p->row * pitch;
  rec->force_n = normal;
  rec->area_m2 = p->taxels * pitch * pitch;
  rec->shift_x_m = finite_or_zero(sx);
  rec->shift_y_m = finite_or_zero(sy);
  rec->force_z_n = -normal;
  rec->confidence = conf;
  rec->valid = valid;
  rec->kept = normal >= c->min_force_n;
  rec->dx = p->dx;
  rec->dy = p->dy;
  rec->index = q;
  rec->censored = p->censored;
  rec->sigma = p->sigma;
  rec->top_force_n = p->top_force;
  rec->bottom_force_n = p->bottom_force;
  rec->shift_confidence = p->confidence;
  rec->held_s = sk_held_s(k, p);
}

/* Write the records of the last scan's contacts to out, strongest first; returns their number. */
static int finish(sk_kernel *k, sk_contact *out)
{
  int count = k->nfound;
  for (int q = 0; q < count; q++) {
    contact(k, q, &out[q]);
    /* strongest first, a stable insertion */
    for (int j = q; j > 0 && out[j - 1].force_n < out[j].force_n; j--) {
      sk_contact tmp = out[j];
      out[j] = out[j - 1];
      out[j - 1] = tmp;
    }
  }
  return count;
}

/*
 * Pair p's force sums with their rim loads (never more than the sum), each saturated layer's
 * filled in from its rim (saturated_force.c). marked: p's window counts with the taxels the ADC
 * cut at full scale (censored there), when p->censored; 2 h w doubles of scratch follow it.
 */
static void imprint_forces(sk_kernel *k, sk_found_contact *p, const double *marked)
{
  double *sums[2] = {&p->top_force, &p->bottom_force};
  int m = p->h * p->w;
  for (int layer = 0; layer < 2; layer++) {
    const sk_curve *curve = &k->s.curves[layer];
    double rim = curve->rim_load_n;
    if (p->censored >> layer & 1) {
      *sums[layer] = sk_imprint_force(marked + layer * m, k->fit + (2 + layer) * m, p->h, p->w,
                                      curve->censor_counts, curve->spread_taxels,
                                      curve->bump_power, curve->activation_n, rim,
                                      k->fit + 6 * m);
    } else {
      *sums[layer] += fmin(rim, *sums[layer]);
    }
  }
}

/* model_fit's fit of contact p's window (its counts in k->fit), each taxel's load times its
 * sensitivity (the inverse of its gain) where the kernel has gains. */
static void model_refit(sk_kernel *k, sk_found_contact *p, const sk_taxel_model *model, const double *marks,
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
static int scan(sk_kernel *k, const double *maps, double time_s, int every_contact,
                sk_shift_fn shift, void *user, sk_contact *out, sk_status *status)
{
  k->revived = 0;
  k->nfound = 0;
  sk_touch_counts(k, maps);
  sk_drift_step(k, maps, time_s);
  sk_force_of(k);
  int count = sk_pair_layers(k);
  k->nfound = count;
  int censored = 0;
  for (int q = 0; q < count; q++) {
    sk_found_contact *p = &k->found[q];
    int m = p->h * p->w;
    sk_contact_window(k, q, k->fit);
    p->censored = 0;
    /* a loaded taxel the ADC clipped is censored whatever its tared counts (condition.c) */
    int clipped = sk_clipped_window(k, p, k->fit, 0);
    for (int layer = 0; layer < 2; layer++) {
      double censor = k->s.curves[layer].censor_counts, peak = 0.0;
      for (int j = 0; j < m; j++) {
        peak = k->fit[layer * m + j] > peak ? k->fit[layer * m + j] : peak;
      }
      if (censor > 0 && (peak >= censor || clipped >> layer & 1)) {
        p->censored |= 1 << layer;
      }
    }
    censored |= p->censored;
    /* the counts with the ADC's clipped taxels marked, for the fill-in and the shift's bounds */
    double *marked = k->fit + 4 * m;
    if (p->censored) {
      memcpy(marked, k->fit, sizeof(double) * 2 * m);
      sk_clipped_window(k, p, marked, 1);
    }
    imprint_forces(k, p, marked);
    p->dx = p->dy = p->confidence = 0.0;
    p->sigma = INFINITY;
    p->cut_var = 0.0;
    if (!every_contact && normal_force(k, p) < k->s.min_force_n) {
      /* too light to report, and its force is final: its shift is never asked for */
      continue;
    }
    double *scratch = k->fit + 4 * m;
    if (shift) {
      double given[3] = {0.0, 0.0, 0.0};
      if (shift(user, k->fit, p->h, p->w, given) == 0) {
        p->dx = given[0];
        p->dy = given[1];
        p->confidence = given[2];
      } else {
        p->dx = p->dy = NAN;
      }
    } else if (k->method == SK_TAXEL_FIT || k->method == SK_MODEL_FIT) {
      /*
       * saturated taxels: at the curve's censoring counts, or clipped by the ADC (condition.c);
       * a contact with none is not censored, and its marks are all 0
       */
      double *marks = marked;
      for (int layer = 0; layer < 2; layer++) {
        double censor = k->s.curves[layer].censor_counts;
        for (int j = layer * m; j < (layer + 1) * m; j++) {
          marks[j] = p->censored && censor > 0 && marks[j] >= censor ? 1.0 : 0.0;
        }
      }
      /* model_fit: taxel_fit's shift, refitted by the calibration's taxel model if it has one */
      const sk_taxel_model *model = &k->s.model;
      int modelled = k->method == SK_MODEL_FIT && model->pitch_m > 0;
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
  status->found = count;
  status->censored = censored;
  status->revived = k->revived != 0;
  for (int layer = 0; layer < 2; layer++) {
    status->drift_mean[layer] = k->drift_mean[layer];
    status->drift_max[layer] = k->drift_max[layer];
  }
  return finish(k, out);
}

/* SK_OK when every value of (2, rows, cols) maps is a count, else what is wrong. */
static int check_maps(const sk_kernel *k, const double *maps)
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
  return SK_OK;
}

int sk_scan(sk_kernel *k, const double *maps, double time_s, int every_contact, sk_contact *out,
            sk_status *status)
{
  int checked = check_maps(k, maps);
  return checked == SK_OK ? scan(k, maps, time_s, every_contact, NULL, NULL, out, status)
    : checked;
}

int sk_scan_shifted(sk_kernel *k, const double *maps, int every_contact, sk_shift_fn shift,
                    void *user, sk_contact *out, sk_status *status)
{
  int checked = check_maps(k, maps);
  return checked == SK_OK ? scan(k, maps, NAN, every_contact, shift, user, out, status)
    : checked;
}

int sk_condition(sk_kernel *k, const double *maps, double *counts, double *force,
                 unsigned char *clipped, double *crosstalk)
{
  int checked = check_maps(k, maps);
  if (checked != SK_OK) {
    return checked;
  }
  k->crosstalk_removed = 0;
  sk_touch_counts(k, maps);
  sk_force_of(k);
  size_t n2 = 2 * (size_t)k->n, lines = 2 * ((size_t)k->rows + k->cols);
  if (counts) {
    memcpy(counts, k->counts, sizeof(double) * n2);
  }
  if (force) {
    memcpy(force, k->force, sizeof(double) * n2);
  }
  if (clipped) {
    memcpy(clipped, k->clipped, n2);
  }
  if (crosstalk) {
    for (size_t i = 0; i < lines; i++) {
      crosstalk[i] = k->crosstalk_removed ? k->line_share[i] : 0.0;
    }
  }
  return SK_OK;
}

int sk_force(const sk_kernel *k, const double *counts, const unsigned char *clipped,
             double *force)
{
  size_t n2 = 2 * (size_t)k->n;
  for (size_t i = 0; i < n2; i++) {
    if (!isfinite(counts[i])) {
      return SK_ERR_NOT_FINITE;
    }
  }
  int whole[4] = {0, k->rows, 0, k->cols};
  sk_force_in(k, counts, clipped, whole, force);
  return SK_OK;
}

int sk_scan_counts(sk_kernel *k, const uint16_t *maps, double time_s, int every_contact,
                   sk_contact *out, sk_status *status)
{
  /* exact as doubles: the scan is sk_scan's to the bit */
  int n2 = 2 * k->n;
  for (int i = 0; i < n2; i++) {
    k->raw[i] = maps[i];
  }
  return scan(k, k->raw, time_s, every_contact, NULL, NULL, out, status);
}

void sk_dead(const sk_kernel *k, unsigned char *out)
{
  memcpy(out, k->dead, 2 * k->n);
}

int sk_carry(sk_kernel *into, const sk_kernel *from)
{
  if (into->rows != from->rows || into->cols != from->cols) {
    return SK_ERR_SETTINGS;
  }
  if (into == from) {
    return SK_OK;
  }
  int n2 = 2 * into->n;
  for (int i = 0; i < n2; i++) {
    /* the drift since each kernel's own tare: a kernel of the same tare has the same one */
    into->baseline[i] = into->tare[i] + (from->baseline[i] - from->tare[i]);
  }
  memcpy(into->age, from->age, sizeof(double) * (size_t)n2);
  into->last_time = from->last_time;
  memcpy(into->dead, from->dead, (size_t)n2);
  sk_live_counts(into);
  return SK_OK;
}
