/*
 * skin_kernel: the per-scan contact estimation of skin_driver, compiled.
 *
 * One call per scan (sk_scan) turns the raw counts of both layers into contacts: conditioning
 * (tare, crosstalk removal, threshold, dead-taxel fill, counts to force), contacts (components,
 * peak split, bottom-load mixture, windows), a saturated imprint's force filled in from its rim,
 * the layer shift of each contact (centroid, taxel_fit, poc or model_fit), its uncertainty and
 * the contact figures. It is the one implementation of the per-scan estimate; skin_driver binds it
 * (skin_driver/core/estimation/scan/kernel.py) and its tests hold it to behaviour and to golden
 * outputs. The conditioning alone (sk_condition, sk_force) is what a calibration reads its
 * presses from, so that it never conditions a scan a second way; the models a calibration
 * learns are written here once too, and it calls them: the direction correction's features
 * (sk_direction_features), the creep law (sk_creep) and the forward model of the taxels
 * (sk_model_render, sk_model_residuals, sk_model_fit_free, ...).
 *
 * A kernel is built once per estimator from its state (tare, gains, force tables, settings) and
 * is not changed afterwards, except for its per-scan state: the dead-taxel marks, which a touch
 * revives (reported), and, for scans given their time, the baselines that follow drift and each
 * taxel's age under load (drift.c). The kernel is the one owner of that state: a kernel built to
 * replace another of the same skin and tare takes it over at the swap (sk_carry), so nothing a
 * scan changed between the new kernel's build and the swap is lost. It is owned by the one
 * thread that runs its scans, and no other thread calls it: the binding copies what others read
 * (the drift of the last scan, the dead marks) after each scan, and can check that only the
 * owner enters a kernel (SKIN_KERNEL_CHECK_OWNER). The kernel takes no lock and keeps no global
 * state, so kernels on different threads run side by side.
 */
#ifndef SKIN_KERNEL_SKIN_KERNEL_H
#define SKIN_KERNEL_SKIN_KERNEL_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/*
 * Bumped whenever a signature or a layout below changes. It is the library's SOVERSION too
 * (libskin_kernel.so.<SK_ABI_VERSION>), and sk_layout reports it with every struct's layout,
 * which the binding compares with its own mirrors before any other call.
 */
#define SK_ABI_VERSION 15

/* Shift methods: centroid, taxel_fit, poc, and model_fit (taxel_fit's shift refitted by the
 * calibration's taxel model, sk_settings.model; taxel_fit's own without one). */
enum { SK_CENTROID = 0, SK_TAXEL_FIT = 1, SK_POC = 2, SK_MODEL_FIT = 3, SK_NMETHODS };

/* A skin's forward model of the taxels (taxelmodel.TaxelModel), SI units; pitch_m 0: none. */
typedef struct {
  double pitch_m, fill_factor;
  double cover_spread_m, layer_spread_m;          /* the blurs */
  double film_scale, film_exponent, film_ceiling, film_activation_n; /* the film's law */
  double turn_on_pa, film_step;                   /* a film that stays open below a pressure */
  double full_scale;                              /* counts */
} sk_taxel_model;

/* One force curve's censoring of a layer (forcecurve.ForceCurve); all 0 (power 2): none. */
typedef struct {
  double censor_counts;   /* counts from which a taxel is saturated; 0: never */
  double rim_load_n;      /* force at an imprint's rim that no taxel reads */
  double spread_taxels;   /* a saturated imprint's bump: spread and power (forcecurve.py) */
  double bump_power;
  double activation_n;    /* force of every conducting taxel, not the bump's */
} sk_curve;

/*
 * A correction of each contact's calibrated shift learned from presses of known direction
 * (calibration/direction.py): shift += weight . features, per axis, in taxels. The features,
 * in order: for h = 1 then 2, sin and cos of 2 pi h
 * (column + raw shift dx) less those of 2 pi h column, then the same of the row and dy; then
 * sin and cos of 2 pi h column, of 2 pi h row, for h = 1 then 2 (the top imprint's phase); then
 * the first four times the normal force over force_ref_n, less 1. on 0: none.
 */
#define SK_DIRECTION_FEATURES 20
typedef struct {
  int on;
  double force_ref_n;
  double weight_x[SK_DIRECTION_FEATURES], weight_y[SK_DIRECTION_FEATURES];
} sk_direction;

/*
 * Time in the scans (drift.c), for scans given their time: track_s, the time constant with which
 * an untouched taxel's baseline follows its reading (a touched one's follows its layer's drift
 * only), 0: none; a loaded taxel's force is divided by its creep c(age) = 1 + creep_per_decade
 * * log10(1 + age / settle_s) over c(1 s), 0: none (a load reads what it read 1 s after it
 * arrived, when a calibration press is read). A taxel's age under load (sk_contact.held_s)
 * grows while it reads a touch and decays by exp(-t / recovery_s) once unloaded (0: at once).
 */
typedef struct {
  double track_s, creep_per_decade, settle_s, recovery_s;
} sk_drift;

/* Everything a kernel is built with besides the per-taxel arrays (SI units). */
typedef struct {
  int rows, cols, max_contacts;
  int method;             /* SK_CENTROID ... */
  int remove_crosstalk, fill_dead;
  int full_scale;         /* the ADC's highest count */
  int tared;              /* 1 once a tare measured noise and rest: the crosstalk gate */
  double pitch_m, compliance_m_per_n, min_force_n, min_confidence, min_shift_m;
  double force_scale, fill_factor;
  /* the calibration: the zero shift at zero_ref_n and its slope with the load */
  double x_p_m, y_p_m, slope_x_m_per_n, slope_y_m_per_n, zero_ref_n;
  double calibration_var; /* the calibration's share of sigma**2, taxels**2 */
  sk_curve curves[2];     /* top, bottom */
  sk_taxel_model model;   /* model_fit's taxel model */
  sk_direction direction; /* the learned correction of the shift */
  sk_drift drift;         /* baseline tracking and creep (scans with a time) */
} sk_settings;

/* One contact of a scan, strongest (normal force) first. */
typedef struct {
  double x_m, y_m, force_n, area_m2, shift_x_m, shift_y_m, azimuth_rad, azimuth_sigma_rad;
  double alpha_rad, force_x_n, force_y_n, force_z_n, confidence;
  double dx, dy;          /* the raw shift, taxels */
  double sigma;           /* 1-sigma of one axis of the shift, taxels */
  double top_force_n, bottom_force_n, shift_confidence;
  int valid;              /* 1 when the direction is meaningful */
  int kept;               /* 1 when the normal force reaches the minimum: a contact to report */
  int index;              /* index of the contact among the scan's found ones */
  int censored;           /* bit 0: the top layer reached its censor counts, bit 1: the bottom */
  double held_s;          /* the longest time under load of its taxels (creep's age), s */
} sk_contact;

/* What a scan found besides its contacts. */
typedef struct {
  int found;              /* contacts found, reported or not */
  int censored;           /* bits as sk_contact.censored, over every contact */
  int revived;            /* 1 when the scan revived dead-taxel marks (sk_dead) */
  /* each layer's baseline drift since the tare (tracked), its mean and largest |drift|, counts */
  double drift_mean[2], drift_max[2];
} sk_status;

/* One field of a struct above (field NULL: the struct's own size), for sk_layout. */
typedef struct {
  const char *type, *field;
  unsigned long offset, size;
} sk_field;

/* Return codes: sk_scan's (a negative count) and sk_new's. */
enum {
  SK_OK = 0, SK_ERR_NOT_FINITE = -1, SK_ERR_NEGATIVE = -2, SK_ERR_SETTINGS = -3,
  SK_ERR_NO_MEMORY = -4
};

typedef struct sk_kernel sk_kernel;

int sk_abi_version(void);

/*
 * The layout of every struct above as this library was compiled: *fields points to a table of
 * the returned count of entries. Returns the ABI version through *abi_version.
 */
int sk_layout(const sk_field **fields, int *abi_version);

/*
 * Build a kernel into *out; every array is copied. settings_size is sizeof(sk_settings) as the
 * caller knows it. baseline, threshold, noise, gain (NULL: none) and dead are (2, rows, cols);
 * tables holds each layer's force at every count 0..full_scale (2 tables). Returns SK_OK, or
 * SK_ERR_SETTINGS with a message (NUL-terminated, at most message_size bytes) saying which
 * setting is not usable, or SK_ERR_NO_MEMORY; *out is NULL then.
 */
int sk_new(const sk_settings *settings, unsigned long settings_size, const double *baseline,
           const double *threshold, const double *noise, const double *gain,
           const unsigned char *dead, const double *tables, sk_kernel **out, char *message,
           unsigned long message_size);

void sk_free(sk_kernel *k);

/*
 * Estimate the contacts of one scan taken at time_s (seconds, any origin; not finite: no time,
 * nothing tracked): maps is the (2, rows, cols) raw counts. Writes one record
 * per contact found (at most max_contacts) to out and the scan's status; returns the number of
 * records, or SK_ERR_NOT_FINITE / SK_ERR_NEGATIVE when the maps hold a value that is not a
 * count. Without every_contact, a contact too light to report (kept 0) gets no shift (0) and no
 * sigma (inf).
 */
int sk_scan(sk_kernel *k, const double *maps, double time_s, int every_contact, sk_contact *out,
            sk_status *status);

/*
 * sk_scan of maps as the ADC gives them, (2, rows, cols) unsigned 16-bit counts: every value is
 * a count, so there is no error to return.
 */
int sk_scan_counts(sk_kernel *k, const uint16_t *maps, double time_s, int every_contact,
                   sk_contact *out, sk_status *status);

/*
 * A shift given by the caller for one contact: window is its (2, h, w) tared counts (top,
 * bottom); writes dx, dy (taxels, the bottom imprint's displacement from the top one) and a
 * confidence in [0, 1] to shift. Returns 0, or anything else for no shift.
 */
typedef int (*sk_shift_fn)(void *user, const double *window, int h, int w, double *shift);

/*
 * sk_scan with each contact's shift from `shift` (called with `user`) instead of the kernel's
 * method: a reference estimator run inside the kernel's pipeline (conditioning, contacts,
 * uncertainty, figures), so that only the shift differs from the kernel's own.
 */
int sk_scan_shifted(sk_kernel *k, const double *maps, int every_contact, sk_shift_fn shift,
                    void *user, sk_contact *out, sk_status *status);

/*
 * The conditioning of one scan alone, as sk_scan does it. Writes, each output NULL when not
 * wanted: counts, the tared counts (crosstalk out, clipped taxels levelled, dead taxels filled),
 * and force, each taxel's force, (2, rows, cols) each; clipped, 1 where a raw count is at the
 * ADC's full scale, (2, rows, cols); crosstalk, the crosstalk taken off each line as a share of
 * its load, each layer's rows then its columns, (2, rows + cols), 0 on a line that gave none and
 * everywhere on a scan whose lines were left as they were. Dead-taxel marks the maps revive
 * are revived, as by a scan. Returns SK_OK or sk_scan's errors.
 */
int sk_condition(sk_kernel *k, const double *maps, double *counts, double *force,
                 unsigned char *clipped, double *crosstalk);

/*
 * The force of given tared counts, (2, rows, cols), through the kernel's force tables and gains,
 * as a scan reads its taxels: a count at or below 0 has none; a taxel that clipped marks (NULL:
 * none) reads the force at full scale. Writes force, (2, rows, cols); returns SK_OK, or
 * SK_ERR_NOT_FINITE when a count is not a number.
 */
int sk_force(const sk_kernel *k, const double *counts, const unsigned char *clipped,
             double *force);

/* Copy the dead-taxel marks in force, (2, rows, cols), to out. */
void sk_dead(const sk_kernel *k, unsigned char *out);

/*
 * Put the per-scan state of kernel `from` in force in `into`, built to replace it for the same
 * skin and tare (a parameter or the calibration changed; a tare starts afresh): the dead-taxel
 * marks, each taxel's baseline drift since the tare and age under load, and the last scan's
 * time. The thread that owns both calls it between two scans, as it swaps `into` in: what
 * `into` was built with is replaced, so a mark revived or a drift followed after its build is
 * kept. Returns SK_OK, or SK_ERR_SETTINGS when the grids differ (nothing carried).
 */
int sk_carry(sk_kernel *into, const sk_kernel *from);

/*
 * Fit a skin's forward model to one contact's window: counts (2, rows, cols) tared counts,
 * censored (2, rows, cols) 1 where a taxel is a lower bound (NULL: none), sensitivity
 * (2, rows, cols) each taxel's load factor (NULL: 1), u0 the start (8 numbers: x, y, log force,
 * dx, dy, log radius, log aspect, orientation). Writes the least-misfit press to u_out and its
 * misfit (counts**2) to misfit_out; returns SK_OK, or SK_ERR_NO_MEMORY.
 */
int sk_model_fit(const sk_taxel_model *model, int rows, int cols, const double *counts,
                 const unsigned char *censored, const double *sensitivity, const double *u0,
                 int iterations, double *u_out, double *misfit_out);

/*
 * The forward model itself, for the calibration that learns it (taxellearn.py, rendered.py):
 * the same render and misfit sk_model_fit uses, at sub fine samples a taxel (0 or less: as
 * sk_model_sub picks for u).
 *
 * sk_model_render writes the (2, rows, cols) counts of press u to counts_out; sk_model_residuals
 * writes the robust residuals of counts (2, rows, cols; a censored taxel's only where the model
 * reads below it) to r_out and their sum of squares to misfit_out. sensitivity as sk_model_fit's.
 * Both return SK_OK, or SK_ERR_NO_MEMORY.
 */
int sk_model_render(const sk_taxel_model *model, int rows, int cols, const double *u, int sub,
                    const double *sensitivity, double *counts_out);
int sk_model_residuals(const sk_taxel_model *model, int rows, int cols, const double *counts,
                       const unsigned char *censored, const double *sensitivity,
                       const double *u, int sub, double *r_out, double *misfit_out);

/*
 * One fit of the model as sk_model_fit makes its first: the tip radius of least misfit among a
 * few around u0's, then Levenberg-Marquardt over the parameters free_ marks (8 flags, u's
 * order; the others stay u0's) for at most `iterations` trials. For a fit that holds some
 * parameters known (the calibration's learning holds the force). Returns as sk_model_fit.
 */
int sk_model_fit_free(const sk_taxel_model *model, int rows, int cols, const double *counts,
                      const unsigned char *censored, const double *sensitivity,
                      const double *u0, const int *free_, int iterations, double *u_out,
                      double *misfit_out);

/* The fine samples a taxel sk_model_fit renders press u with (fixed through a fit). */
int sk_model_sub(const double *u);

/*
 * A fit's start from a window's (2, h, w) force (or counts) maps: the top layer's centroid, its
 * tip radius from its second moment less the cover's blur and the pad's own, the larger layer's
 * sum over the pad's share as the force; the shift and the ellipse 0. Writes the 8 numbers of u
 * to start (its force NaN without memory).
 */
void sk_model_start(const sk_taxel_model *model, const double *force, int h, int w,
                    double *start);

/*
 * The fit's numbers, for a fit of the model made elsewhere (the calibration's joint learning of
 * a skin and its presses): each parameter's finite-difference step and largest move (8 each,
 * u's order) and the tip radius's scales tried around a start (6).
 */
void sk_model_steps(double *steps, double *max_moves, double *radius_scales);

/*
 * The direction correction's features (sk_direction's order) of n contacts: their places col,
 * row and raw shifts dx, dy (taxels) and normal forces normal_n, the force feature taken
 * relative to force_ref_n (> 0). Writes (n, SK_DIRECTION_FEATURES) to out: what a scan applies
 * a correction's weights to, and what the calibration fits them on.
 */
void sk_direction_features(int n, const double *col, const double *row, const double *dx,
                           const double *dy, const double *normal_n, double force_ref_n,
                           double *out);

/*
 * The creep law of sk_drift, the one the scans correct by and the creep calibration fits: after
 * age_s under load a reading has risen to c(age) = 1 + creep_per_decade log10(1 + age /
 * settle_s) times what it read at the load's arrival (a negative age counts as 0). Writes c of
 * n ages to out; with relative_to_1s, c(age) / c(1 s) instead: what a scan divides a loaded
 * taxel's force by. Only creep_per_decade and settle_s (> 0) are read.
 */
void sk_creep(const sk_drift *drift, int n, const double *age_s, int relative_to_1s,
              double *out);

#ifdef __cplusplus
}
#endif

#endif
