/* The kernel's state and the stages' entry points, shared by the source files. */
#ifndef SKIN_KERNEL_INTERNAL_H
#define SKIN_KERNEL_INTERNAL_H

#include "skin_kernel/skin_kernel.h"

/* One contact of the last scan: its window and the figures found before the contact stage. */
typedef struct {
  int r0, c0, h, w;       /* window in the full map */
  double row, col;        /* top centroid, taxels */
  double peak;            /* highest share of a bottom taxel, counts */
  double top_force, bottom_force;
  int taxels, at_border, censored;
  int bottom_cut;          /* the bottom share's strongest line is the map's edge line */
  double dx, dy, confidence, sigma;
  double cut_var;          /* taxel_fit's variance of its profiles cut by the edge; 0: none */
} sk_found_contact;

struct sk_kernel {
  sk_settings s;                    /* as built; rows, cols, ... below are copies */
  int rows, cols, n, kmax, method, crosstalk, fill_dead, full_scale, has_gain, tared;
  /* the estimator's state, (2, n) each */
  double *baseline, *threshold, *noise, *gain;
  double *crosstalk_gate;                /* (2, n): a line is lifted at this count (crosstalk.c) */
  unsigned char *dead;
  int any_dead[2];
  unsigned char *clipped;           /* (2, n): the last scan's raw count at the ADC's full scale */
  int any_clipped;
  double *live, *live_count;        /* dead fill: live taxels and their count per 3 x 3 */
  double *table_force;              /* 2 x (full_scale + 1) */
  /* the last scan */
  double *raw;                      /* (2, n): sk_scan_counts's maps as doubles */
  double *counts, *force;           /* (2, n): tared counts, force */
  /* each layer's rows' then columns' leak as a share of the line's load (2 (rows + cols)),
   * valid when crosstalk_removed */
  double *line_share;
  int crosstalk_removed;
  /*
   * rows box[0]..box[1] and columns box[2]..box[3] (half-open) hold every taxel of either
   * layer whose tared count is not 0: the loops of the contact stage skip the rest
   */
  int box[4];
  int nfound;
  sk_found_contact *found;                   /* kmax */
  /* (kmax, n): each contact's own top map and its share (0..1) of every bottom taxel */
  double *tops, *fractions;
  /* scratch */
  double *scratch;                  /* 4 n + 16 kmax + 4 (max(rows, cols) + 1) */
  int *labels, *iscratch;           /* n, 4 n */
  double *fit;                      /* a contact's 4 windows (4 n), then the shift's scratch */
  int revived;
  /* time (drift.c): the tare's baseline, each taxel's age under load, the last scan's time */
  double *tare, *age;
  double last_time, drift_mean[2], drift_max[2];
  double creep_at_1s;               /* 1 / the creep of a load held 1 s (the reference) */
};

/* The sum of n numbers in order (the sums are of at most a window's taxels, so a plain loop
 * loses no accuracy that matters next to the counts' own noise). */
static inline double sk_sum(const double *a, int n)
{
  double res = 0.0;
  for (int i = 0; i < n; i++) {
    res += a[i];
  }
  return res;
}

/* condition.c: each layer's live taxels and their count per 3 x 3, from k->dead */
void sk_live_counts(sk_kernel *k);

/* crosstalk.c: the count at which a line is lifted (k->crosstalk_gate), once per kernel; each
 * lifted scan's crosstalk taken out of k->counts */
void sk_crosstalk_gate(sk_kernel *k);
void sk_remove_crosstalk(sk_kernel *k);
void sk_touch_counts(sk_kernel *k, const double *maps);
/* the force of tared counts (2, n) through k's tables and gains, taxels in box (rows box[0] to
 * box[1], columns box[2] to box[3], half-open) read, the rest 0; clipped (NULL: none) taxels
 * with a count read the force at full scale. sk_force_of: k's own counts to k->force */
void sk_force_in(const sk_kernel *k, const double *counts, const unsigned char *clipped,
                 const int *box, double *force);
void sk_force_of(sk_kernel *k);
/* contact p's layers (bits 0, 1) holding a loaded taxel the ADC clipped; with mark, such taxels of
 * its window (sk_contact_window) are put at full scale, where a force curve censors them */
int sk_clipped_window(const sk_kernel *k, const sk_found_contact *p, double *window, int mark);

/* contacts.c: fills k->found (geometry and forces), returns their number */
int sk_pair_layers(sk_kernel *k);
/* mixture.c: each of the kn tops' share (k->fractions) of the loaded bottom taxels */
void sk_share_bottom(sk_kernel *k, int kn, const double *bottom);
/* contacts.c: contact q's window, counts (top, bottom) then its share of the force maps */
void sk_contact_window(const sk_kernel *k, int q, double *out);

/* drift.c: the time's step of a scan at time_s (after its touch counts), a taxel's creep factor
 * (index into the (2, n) maps), the longest age under load in contact p's window */
void sk_drift_step(sk_kernel *k, const double *maps, double time_s);
double sk_creep_factor(const sk_kernel *k, int i);
double sk_held_s(const sk_kernel *k, const sk_found_contact *p);
/* drift.c: the creep law, a reading's rise after age_s under load (1 at its arrival) */
double sk_creep_rise(const sk_drift *d, double age_s);

#define SK_PI 3.14159265358979323846

/* Bottom load below this share of a contact's peak share is not part of its window. */
#define WINDOW_SHARE 0.02

/* the profile fits' constants, shared by taxel_fit.c and censored_fit.c: the narrowest width
 * (taxels) and how far past the window's edge a cut profile's centre may lie */
#define MIN_WIDTH 0.25
#define PAST_EDGE 2.0 /* widths */
#define INV_SQRT2PI 0.3989422804014327

/* x within [lo, hi]; comparisons keep a NaN */
static inline double sk_clip(double x, double lo, double hi)
{
  return x < lo ? lo : (x > hi ? hi : x);
}

/* solve.c: the n x n system a x = b (a row-major, both overwritten; x left in b), n at most
 * SK_SOLVE_MAX, by LU factorisation with partial pivoting; returns 0 for a zero pivot (or an n
 * out of range), else 1 */
#define SK_SOLVE_MAX 8
int sk_solve(double *a, double *b, int n);

/* gaussian_cells.c: the normal CDF to 1.5e-7 (Abramowitz and Stegun) */
double sk_normal_cdf(double u);
/* the same, given gauss = exp(-u^2 / 2) (a density's, at hand) */
double sk_normal_cdf_of(double u, double gauss);
/* a Gaussian's (centre mu, width s, taxels) share of each of n unit cells and its derivatives
 * by mu and s */
void sk_axis_cells(double mu, double s, int n, double *g, double *d_mu, double *d_s);

/* centroid.c: a layer's column profiles (summed over rows, in row order) and row profiles (each
 * row summed in order), each buffer nn = max(h, w) long */
void sk_profiles_of(const double *layer, int h, int w, int nn, double *along_x,
                    double *along_y);
/* centroid.c: the shift of a (2, h, w) window of counts as the difference of the centroids */
void sk_centroid(const double *counts, int h, int w, double *scratch, double *dx, double *dy,
                 double *confidence);

/*
 * censored_fit.c: the saturated layers of a (2, h, w) window refitted in 2-D, in place on the
 * marginal fits' centres (x top, x bottom, y top, y bottom); width likewise
 */
void sk_censored_centres(const double *force, const double *censored, int h, int w,
                         double *scratch, double *centre, const double *width);

/*
 * taxel_fit.c: the shift of a (2, h, w) window; censored: 1 where a taxel is saturated; force's
 * taxels on a film's turn-on step are halved in place; cut_var: the variance (taxels**2) of the
 * profiles cut by the map's edge (0 when none is)
 */
void sk_taxel_fit(double *force, const double *counts, const double *censored, int h, int w,
                  double *scratch, double *dx, double *dy, double *confidence,
                  double *cut_var);

/* phase_correlation.c: the shift by band-limited phase correlation (poc), and the scratch it
 * needs (doubles) */
void sk_poc(const double *maps, int h, int w, double *scratch, double *dx, double *dy,
            double *confidence);
int sk_poc_scratch(int h, int w);

/* saturated_force.c: one imprint's force sum (h x w counts and force), each taxel at censor
 * counts or more filled in by the activation plus a bump of spread (taxels) and power fitted to
 * its rim's force above the activation, the rim load added; scratch holds 3 h w doubles */
double sk_imprint_force(const double *counts, const double *force, int h, int w,
                        double censor, double spread, double power, double activation,
                        double rim, double *scratch);

/* uncertainty.c: 1-sigma uncertainty of one axis of contact p's shift (taxels) */
double sk_sigma(const sk_kernel *k, const sk_found_contact *p, const double *window, int alone);

/* model_fit.c: the fit from sk_model_start's start (taken before sk_taxel_fit changes the
 * window) and taxel_fit's shift, which overwrites *dx, *dy (left as they are when the fit
 * cannot be made). */
void sk_model_refit(const sk_taxel_model *model, const double *counts, const double *marks,
                    const double *sensitivity, int h, int w, double *start, double *dx,
                    double *dy);

/* direction.c: the learned correction of a calibrated shift (metres, in place) and whether a
 * correction's numbers can be used; dx, dy the raw shift (taxels) */
void sk_direction_correct(const sk_direction *d, double col, double row, double dx, double dy,
                          double normal_n, double pitch_m, double *sx_m, double *sy_m);
int sk_direction_usable(const sk_direction *d);

#endif
