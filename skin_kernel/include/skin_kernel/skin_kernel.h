/*
 * skin_kernel: the per-scan contact estimation of skin_driver, compiled.
 *
 * One call per scan (sk_scan) turns the raw counts of both layers into contacts: conditioning
 * (tare, line-leak removal, threshold, dead-taxel fill, counts to force), contacts (components,
 * peak split, bottom-load mixture, windows), a saturated imprint's force filled in from its rim,
 * the layer shift of each contact (taxel_fit, poc or centroid), its uncertainty and the contact
 * figures. The algorithm's description is the Python
 * package skin_driver.core.estimation, which the tests run side by side with this library.
 *
 * A kernel is built once per estimator from its state (tare, gains, force tables, settings) and
 * is not changed afterwards, except for dead-taxel marks that a touch revives (reported).
 */
#ifndef SKIN_KERNEL_SKIN_KERNEL_H
#define SKIN_KERNEL_SKIN_KERNEL_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Bumped whenever a signature or a layout below changes; the binding checks it. */
#define SK_ABI_VERSION 8

/* Integer settings, in this order. */
enum {
  SK_ROWS, SK_COLS, SK_MAX_CONTACTS, SK_METHOD, SK_REMOVE_CROSSTALK, SK_FILL_DEAD,
  SK_FULL_SCALE, SK_HAS_GAIN,
  SK_TARED, /* 1 once a tare measured noise and rest: the line-leak gate (crosstalk.py) */
  SK_NINTS
};

/* Shift methods. */
enum { SK_CENTROID = 0, SK_TAXEL_FIT = 1, SK_POC = 2, SK_MODEL_FIT = 3 };

/* A skin's forward model of the taxels (taxelmodel.TaxelModel), SI units, in this order. */
enum {
  SK_MODEL_PITCH, SK_MODEL_FILL, SK_MODEL_COVER, SK_MODEL_LAYER, /* blurs: spreads, m */
  SK_MODEL_SCALE, SK_MODEL_EXPONENT, SK_MODEL_CEILING, SK_MODEL_ACTIVATION, /* the film's law */
  SK_MODEL_TURN_ON, SK_MODEL_STEP, /* a film that stays open below a pressure (Pa) */
  SK_MODEL_FULL_SCALE,
  SK_MODEL_NREALS
};

/* Real settings, in this order (SI units; the calibration's numbers included). */
enum {
  SK_PITCH, SK_COMPLIANCE, SK_MIN_FORCE, SK_MIN_CONFIDENCE, SK_MIN_SHIFT, SK_FORCE_SCALE,
  SK_FILL_FACTOR, SK_X_P, SK_Y_P, SK_SLOPE_X, SK_SLOPE_Y, SK_ZERO_REF,
  SK_CALIBRATION_VAR, /* the calibration's share of sigma**2, taxels**2 */
  SK_CENSOR_TOP, SK_CENSOR_BOTTOM, /* counts from which a taxel is saturated; 0: never */
  SK_RIM_TOP, SK_RIM_BOTTOM, /* force at an imprint's rim that no taxel reads (forcecurve) */
  SK_SPREAD_TOP, SK_SPREAD_BOTTOM, /* a saturated imprint's bump: spread (taxels), power */
  SK_POWER_TOP, SK_POWER_BOTTOM,   /* (imprint.py) */
  SK_ACTIVATION_TOP, SK_ACTIVATION_BOTTOM, /* force of every conducting taxel, not the bump's */
  SK_TAXEL_MODEL, /* SK_MODEL_NREALS numbers: the calibration's taxel model (pitch 0: none) */
  SK_NREALS = SK_TAXEL_MODEL + SK_MODEL_NREALS
};

/* One output record per contact, SK_NREC doubles, strongest (normal force) first. */
enum {
  SK_X_M, SK_Y_M, SK_FORCE_N, SK_AREA_M2, SK_SHIFT_X_M, SK_SHIFT_Y_M, SK_AZIMUTH,
  SK_AZIMUTH_SIGMA, SK_ALPHA, SK_FORCE_X, SK_FORCE_Y, SK_FORCE_Z, SK_CONFIDENCE, SK_VALID,
  SK_KEPT,        /* 1 when the normal force reaches the minimum: a contact to report */
  SK_DX, SK_DY,   /* the raw shift, taxels */
  SK_PAIR,        /* index of the contact among the scan's pairs */
  SK_CENSORED,    /* bit 0: the top layer reached its censor counts, bit 1: the bottom */
  SK_SIGMA, SK_TOP_FORCE, SK_BOTTOM_FORCE, SK_SHIFT_CONFIDENCE,
  SK_NREC
};

/* sk_scan's status words. */
enum { SK_STATUS_PAIRS, SK_STATUS_CENSORED, SK_STATUS_REVIVED, SK_NSTATUS };

/* sk_scan's errors (negative return values). */
enum { SK_ERR_NOT_FINITE = -1, SK_ERR_NEGATIVE = -2 };

typedef struct sk_kernel sk_kernel;

int sk_abi_version(void);

/*
 * Build a kernel; every array is copied. baseline, threshold, noise, gain (NULL: none) and dead
 * are (2, rows, cols); tables holds each layer's force at every count 0..full_scale (2 tables).
 * Returns NULL when out of memory or when the sizes are not usable.
 */
sk_kernel *sk_new(const int *ints, const double *reals, const double *baseline,
                  const double *threshold, const double *noise, const double *gain,
                  const unsigned char *dead, const double *tables);

void sk_free(sk_kernel *k);

/*
 * Estimate the contacts of one scan: maps is the (2, rows, cols) raw counts. Writes one record
 * per contact found (at most max_contacts) to out and SK_NSTATUS words to status; returns the
 * number of records, or an SK_ERR_* when the maps hold a value that is not a count. Without
 * every_pair, a contact too light to report (SK_KEPT 0) gets no shift (0) and no sigma (inf).
 */
int sk_scan(sk_kernel *k, const double *maps, int every_pair, double *out, int *status);

/*
 * sk_scan of maps as the ADC gives them, (2, rows, cols) unsigned 16-bit counts: every value is
 * a count, so there is no error to return.
 */
int sk_scan_counts(sk_kernel *k, const uint16_t *maps, int every_pair, double *out, int *status);

/* Copy the dead-taxel marks in force, (2, rows, cols), to out. */
void sk_dead(const sk_kernel *k, unsigned char *out);

/*
 * Fit a skin's forward model (model: SK_MODEL_NREALS numbers) to one contact's window: counts
 * (2, rows, cols) tared counts, censored (2, rows, cols) 1 where a taxel is a lower bound (NULL:
 * none), sensitivity (2, rows, cols) each taxel's load factor (NULL: 1), u0 the start (8
 * numbers: x, y, log force, dx, dy, log radius, log aspect, orientation). Writes the least-misfit
 * press to u_out and its misfit (counts**2) to misfit_out; returns 0, or -1 when out of memory.
 */
int sk_model_fit(const double *model, int rows, int cols, const double *counts,
                 const unsigned char *censored, const double *sensitivity, const double *u0,
                 int iterations, double *u_out, double *misfit_out);

#ifdef __cplusplus
}
#endif

#endif
