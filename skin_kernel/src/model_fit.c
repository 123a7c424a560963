/*
 * The forward model of the taxels fitted to one contact (model_fit): a Hertz tip on a fine
 * grid, blurred and summed per active pad by separable operators, a film law per taxel,
 * Levenberg-Marquardt on the counts (steps solved by solve.c). The model is the one the
 * simulator renders with and the force calibration learns (model/taxelmodel.py).
 *
 * The operators are tabulated once per fit: along an axis, the weight of fine sample j in cell
 * k depends only on j - k * sub (a pad's overlap with each fine sample, convolved with the
 * blur's kernel), so a render reads them from two short tables instead of building matrices.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

enum { X, Y, LOG_FORCE, DX, DY, LOG_RADIUS, LOG_ASPECT, ORIENTATION, NU };
_Static_assert(NU <= SK_SOLVE_MAX, "a step of every parameter fits the solver");

static const double STEPS[NU] = {0.02, 0.02, 0.01, 0.02, 0.02, 0.03, 0.03, 0.05};
static const double MAX_MOVES[NU] = {0.5, 0.5, 0.5, 1.0, 1.0, 0.3, 0.3, 0.5};
static const double RADIUS_SCALES[6] = {0.5, 0.63, 0.8, 1.0, 1.25, 1.6};
#define LOG_ASPECT_LIMIT 0.9
#define ROBUST_SHARE 0.05
#define PI 3.14159265358979323846

/* One axis's operator along a fine axis of `sub` samples a cell: tab[d + half] for the weight
 * of fine sample j in cell k, d = j - k * sub, d in [-half, sub - 1 + half]. */
typedef struct {
  double *tab;
  int half, len;
  double *kernel; /* the blur's Gaussian (OpenCV's), size 2 * half + 1; NULL: no blur */
} axis_tab;

typedef struct {
  const sk_taxel_model *model;
  int h, w, sub;
  const double *counts, *sensitivity;
  const unsigned char *censored;
  double fill, turn_on, blur[2];
  double *weights; /* a pad's overlap with each fine sample, sub of them */
  axis_tab tabs[2]; /* top, bottom */
  double *fine, *tmp, *load, *layer, *axes;
  size_t fine_cap, tmp_cap, load_cap, axes_cap;
  int failed;
} fit_ctx;

/* cv2.getGaussianKernel(size, sigma, CV_64F) with the size cv2.GaussianBlur picks. */
static double *gaussian_kernel(double sigma, int *half) {
  int size = ((int)nearbyint(sigma * 4 * 2 + 1)) | 1;
  double *k = malloc(sizeof(double) * (size_t)size), sum = 0.0;
  if (!k) return NULL;
  double scale = -0.5 / (sigma * sigma);
  for (int i = 0; i < size; i++) {
    double x = i - (size - 1) * 0.5;
    k[i] = exp(scale * x * x);
    sum += k[i];
  }
  for (int i = 0; i < size; i++) k[i] *= 1.0 / sum;
  *half = size / 2;
  return k;
}

static void cell_weights(int sub, double fill, double *out) {
  double lo = 0.5 - fill / 2.0, hi = 0.5 + fill / 2.0;
  for (int t = 0; t < sub; t++) {
    double a = (double)t / sub, b = (double)(t + 1) / sub;
    double v = (b < hi ? b : hi) - (a > lo ? a : lo);
    out[t] = (v > 0.0 ? v : 0.0) * sub;
  }
}

static int build_tab(axis_tab *ax, const double *weights, int sub, double blur_px) {
  ax->kernel = NULL;
  ax->half = 0;
  if (blur_px > 0) {
    ax->kernel = gaussian_kernel(blur_px, &ax->half);
    if (!ax->kernel) return -1;
  }
  ax->len = sub + 2 * ax->half;
  ax->tab = calloc((size_t)ax->len, sizeof(double));
  if (!ax->tab) return -1;
  for (int i = 0; i < ax->len; i++) {
    int d = i - ax->half;
    if (!ax->kernel) {
      ax->tab[i] = weights[d];
      continue;
    }
    /* sum over the cell's fine samples t of w[t] * kernel[j - (k sub + t) + half] */
    double acc = 0.0;
    for (int t = 0; t < sub; t++) {
      int q = d - t + ax->half;
      if (q >= 0 && q < 2 * ax->half + 1) acc += weights[t] * ax->kernel[q];
    }
    ax->tab[i] = acc;
  }
  return 0;
}

static int reserve(double **buf, size_t *cap, size_t n) {
  if (n <= *cap) return 0;
  double *p = realloc(*buf, sizeof(double) * n);
  if (!p) return -1;
  *buf = p;
  *cap = n;
  return 0;
}

/* The fine samples within the tip's reach of `centre` along an axis of `cells` cells (plus the
 * margins): first index and count, or count 0. */
static int fine_axis(double centre, double reach, int margin, int cells, int sub, int *first) {
  double origin = margin + 0.5;
  int lo = (int)floor((centre - reach + origin) * sub - 0.5);
  int hi = (int)ceil((centre + reach + origin) * sub - 0.5) + 1;
  if (lo < 0) lo = 0;
  if (hi > (cells + 2 * margin) * sub) hi = (cells + 2 * margin) * sub;
  *first = lo;
  return hi > lo ? hi - lo : 0;
}

/* The indices j in [0, n) with start <= j < start + len, as [lo, hi). */
static void band(int start, int len, int n, int *lo, int *hi) {
  *lo = start < 0 ? 0 : start;
  *hi = start + len > n ? n : start + len;
  if (*hi < *lo) *hi = *lo;
}

/* The fine samples n from `first` reach by the blur, within an axis of `total`: [*lo, +count). */
static int spread_span(int first, int n, int reach, int total, int *lo) {
  int hi;
  band(first - reach, n + 2 * reach, total, lo, &hi);
  return hi - *lo;
}

/* A film that turns on where the blurred fine load exceeds its threshold: blur on the fine
 * grid, cut, then sum per pad (taxelmodel._sensed). Layer `which`: 0 top, 1 bottom. */
static void sensed(fit_ctx *c, int which, const double *fine, int ny, int nx, int y0, int x0,
                   int margin, double *out) {
  int h = c->h, w = c->w, sub = c->sub;
  const axis_tab *tab = &c->tabs[which];
  double threshold = c->turn_on / ((double)sub * sub);
  int half = tab->half, size = 2 * half + 1;
  static const double one = 1.0;
  const double *kern = tab->kernel ? tab->kernel : &one;
  int reach_px = (int)ceil(4.0 * (c->blur[which] * sub)) + 1;
  int lo_y, lo_x;
  int my = spread_span(y0, ny, reach_px, (h + 2 * margin) * sub, &lo_y);
  int mx = spread_span(x0, nx, reach_px, (w + 2 * margin) * sub, &lo_x);
  if (reserve(&c->tmp, &c->tmp_cap, (size_t)my * nx) ||
      reserve(&c->load, &c->load_cap, (size_t)my * mx + (size_t)h * mx)) {
    c->failed = 1;
    return;
  }
  double *tmp = c->tmp, *load = c->load, *part = c->load + (size_t)my * mx;
  /* tmp = spread_y (my x ny) @ fine: row r reads the kernel at (y0 + i) - (lo_y + r) + half */
  for (int r = 0; r < my; r++) {
    double *t = tmp + (size_t)r * nx;
    for (int j = 0; j < nx; j++) t[j] = 0.0;
    int lo, hi;
    band(lo_y + r - half - y0, size, ny, &lo, &hi);
    for (int i = lo; i < hi; i++) {
      double kv = kern[(y0 + i) - (lo_y + r) + half];
      const double *f = fine + (size_t)i * nx;
      for (int j = 0; j < nx; j++) t[j] += kv * f[j];
    }
  }
  /* load = tmp @ spread_x.T, cut at the threshold. Entry (r, s) sums tmp[r, j] times the
   * kernel at (x0 + j) - (lo_x + s) + half; the kernel is symmetric, so sample j adds
   * tmp[r, j] kern[q] to s = x0 + j - lo_x - half + q: an axpy along s. */
  for (int r = 0; r < my; r++) {
    const double *t = tmp + (size_t)r * nx;
    double *row = load + (size_t)r * mx;
    for (int s = 0; s < mx; s++) row[s] = 0.0;
    for (int j = 0; j < nx; j++) {
      int start = x0 + j - lo_x - half, lo, hi;
      band(-start, mx, size, &lo, &hi);  /* q with 0 <= start + q < mx */
      double tv = t[j];
      for (int q = lo; q < hi; q++) row[start + q] += tv * kern[q];
    }
    for (int s = 0; s < mx; s++)
      if (row[s] <= threshold) row[s] = 0.0;
  }
  /* out = sums_y (h x my) @ load @ sums_x.T (mx x w) */
  for (int k = 0; k < h; k++) {
    double *p = part + (size_t)k * mx;
    for (int s = 0; s < mx; s++) p[s] = 0.0;
    int lo, hi;
    band((margin + k) * sub - lo_y, sub, my, &lo, &hi);
    for (int r = lo; r < hi; r++) {
      double wv = c->weights[(lo_y + r) - (margin + k) * sub];
      for (int s = 0; s < mx; s++) p[s] += wv * load[(size_t)r * mx + s];
    }
    for (int col = 0; col < w; col++) {
      band((margin + col) * sub - lo_x, sub, mx, &lo, &hi);
      double acc = 0.0;
      for (int s = lo; s < hi; s++) acc += p[s] * c->weights[(lo_x + s) - (margin + col) * sub];
      out[k * w + col] = acc;
    }
  }
}

/* One layer's per-taxel load (h x w) into out; the tip centred at (cx, cy). */
static void render_layer(fit_ctx *c, double cx, double cy, const double *u, int which,
                         double *out) {
  int h = c->h, w = c->w, sub = c->sub;
  double blur = c->blur[which];
  memset(out, 0, sizeof(double) * (size_t)(h * w));
  double a = exp(sk_clip(u[LOG_RADIUS], log(0.05), log(4.0)));
  double aspect = exp(sk_clip(u[LOG_ASPECT], -LOG_ASPECT_LIMIT, LOG_ASPECT_LIMIT));
  double reach = a * (aspect > 1.0 ? aspect : 1.0);
  int margin = (int)ceil(reach + 4.0 * blur) + 1;
  double step = 1.0 / sub, origin = margin + 0.5;
  int x0, y0;
  int nx = fine_axis(cx, reach, margin, w, sub, &x0);
  int ny = fine_axis(cy, reach, margin, h, sub, &y0);
  if (nx == 0 || ny == 0) return;
  if (reserve(&c->fine, &c->fine_cap, (size_t)nx * ny) ||
      reserve(&c->axes, &c->axes_cap, (size_t)(nx + ny))) {
    c->failed = 1;
    return;
  }
  double *fine = c->fine, *xs = c->axes, *ys = c->axes + nx, total = 0.0;
  for (int j = 0; j < nx; j++) xs[j] = (x0 + j + 0.5) * step - origin - cx;
  for (int i = 0; i < ny; i++) ys[i] = (y0 + i + 0.5) * step - origin - cy;
  if (aspect == 1.0) {
    double aa = a * a;
    for (int i = 0; i < ny; i++) {
      double dy2 = ys[i] * ys[i], *row = fine + (size_t)i * nx;
      for (int j = 0; j < nx; j++) {
        double v = 1.0 - (xs[j] * xs[j] + dy2) / aa;
        row[j] = v > 0.0 ? v : 0.0;
      }
      for (int j = 0; j < nx; j++) row[j] = sqrt(row[j]);
    }
  } else {
    double co = cos(u[ORIENTATION]), si = sin(u[ORIENTATION]), b = a * aspect;
    for (int i = 0; i < ny; i++) {
      double dy = ys[i], *row = fine + (size_t)i * nx;
      for (int j = 0; j < nx; j++) {
        double p = (xs[j] * co + dy * si) / a, q = (dy * co - xs[j] * si) / b;
        double v = 1.0 - (p * p + q * q);
        row[j] = v > 0.0 ? v : 0.0;
      }
      for (int j = 0; j < nx; j++) row[j] = sqrt(row[j]);
    }
  }
  for (int k = 0; k < nx * ny; k++) total += fine[k];
  if (!(total > 0.0)) return;
  double scale = exp(u[LOG_FORCE]) / total;
  for (int k = 0; k < nx * ny; k++) fine[k] *= scale;
  const axis_tab *tab = &c->tabs[which];

  if (c->turn_on > 0.0) {
    sensed(c, which, fine, ny, nx, y0, x0, margin, out);
    return;
  }
  /* out = op_y (h x ny) @ fine @ op_x.T (nx x w); each cell sees only the fine samples its
   * operator reaches (d = j - k sub within [-half, sub - 1 + half]). */
  if (reserve(&c->tmp, &c->tmp_cap, (size_t)h * nx)) { c->failed = 1; return; }
  double *tmp = c->tmp;
  for (int k = 0; k < h; k++) {
    double *t = tmp + (size_t)k * nx;
    for (int j = 0; j < nx; j++) t[j] = 0.0;
    int lo, hi;
    band((margin + k) * sub - tab->half - y0, tab->len, ny, &lo, &hi);
    for (int i = lo; i < hi; i++) {
      double ov = tab->tab[(y0 + i) - (margin + k) * sub + tab->half];
      const double *f = fine + (size_t)i * nx;
      for (int j = 0; j < nx; j++) t[j] += ov * f[j];
    }
  }
  for (int col = 0; col < w; col++) {
    int lo, hi;
    band((margin + col) * sub - tab->half - x0, tab->len, nx, &lo, &hi);
    int off = x0 - (margin + col) * sub + tab->half;
    for (int k = 0; k < h; k++) {
      const double *t = tmp + (size_t)k * nx;
      double acc = 0.0;
      for (int j = lo; j < hi; j++) acc += t[j] * tab->tab[j + off];
      out[k * w + col] = acc;
    }
  }
}

/* The film's law: the counts of a taxel's load f (newtons, its sensitivity applied). */
static double film_counts(const sk_taxel_model *m, double f) {
  double load = f - m->film_activation_n;
  if (load < 0.0) load = 0.0;
  double g = m->film_scale * pow(load, m->film_exponent);
  if (g > m->film_ceiling) g = m->film_ceiling;
  if (m->film_step > 0.0 && f > 0.0 && g < m->film_step) g = m->film_step;
  return m->full_scale * g / (1.0 + g);
}

/* The robust residuals (2 h w of them) of the layers' per-taxel loads into r; returns the
 * misfit r . r. */
static double film_residuals(const fit_ctx *c, const double *loads, double *r) {
  const sk_taxel_model *m = c->model;
  int n = c->h * c->w;
  double scale = m->full_scale * ROBUST_SHARE, cost = 0.0;
  for (int k = 0; k < 2 * n; k++) {
    double f = loads[k] * (c->sensitivity ? c->sensitivity[k] : 1.0);
    double v = film_counts(m, f) - c->counts[k];
    if (c->censored && c->censored[k] && v > 0.0) v = 0.0;
    v /= scale;
    double s = (v > 0.0) - (v < 0.0);
    r[k] = s * scale * sqrt(2.0 * (sqrt(1.0 + v * v) - 1.0));
    cost += r[k] * r[k];
  }
  return cost;
}

/* The residuals of press u into r (its loads left in c->layer); returns the misfit. */
static double residuals(fit_ctx *c, const double *u, double *r) {
  int n = c->h * c->w;
  render_layer(c, u[X], u[Y], u, 0, c->layer);
  render_layer(c, u[X] + u[DX], u[Y] + u[DY], u, 1, c->layer + n);
  return film_residuals(c, c->layer, r);
}

/* The residuals of u moved by `step` along parameter j, from the loads `base` of u itself: a
 * shift moves the bottom layer alone, and a force scales both layers' loads unless the film
 * turns on (its cut on the fine grid does not scale). */
static void probe_residuals(fit_ctx *c, const double *u, const double *base, int j, double step,
                            double *r) {
  int n = c->h * c->w;
  double v[NU];
  memcpy(v, u, sizeof v);
  v[j] += step;
  if (j == LOG_FORCE && !(c->turn_on > 0.0)) {
    double ratio = exp(v[LOG_FORCE]) / exp(u[LOG_FORCE]);
    for (int k = 0; k < 2 * n; k++) c->layer[k] = base[k] * ratio;
  } else if (j == DX || j == DY) {
    memcpy(c->layer, base, sizeof(double) * (size_t)n);
    render_layer(c, v[X] + v[DX], v[Y] + v[DY], v, 1, c->layer + n);
  } else {
    render_layer(c, v[X], v[Y], v, 0, c->layer);
    render_layer(c, v[X] + v[DX], v[Y] + v[DY], v, 1, c->layer + n);
  }
  film_residuals(c, c->layer, r);
}

/* Levenberg-Marquardt over the free parameters (taxelmodel.levenberg_marquardt). */
static double levenberg_marquardt(fit_ctx *c, double *u, const int *free_, int iterations,
                                  double *r, double *r2, double *jac, double *probe,
                                  double *base) {
  int idx[NU], nf = 0, n = 2 * c->h * c->w;
  for (int j = 0; j < NU; j++)
    if (free_[j]) idx[nf++] = j;
  double cost = residuals(c, u, r), damping = 1e-3;
  memcpy(base, c->layer, sizeof(double) * (size_t)n);
  double trial[NU], normal[NU * NU], rhs[NU], move[NU];
  int stale = 1;
  for (int it = 0; it < iterations; it++) {
    if (stale) {  /* forward differences at u */
      for (int k = 0; k < nf; k++) {
        probe_residuals(c, u, base, idx[k], STEPS[idx[k]], probe);
        for (int q = 0; q < n; q++) jac[q * nf + k] = (probe[q] - r[q]) / STEPS[idx[k]];
      }
      stale = 0;
    }
    for (int a = 0; a < nf; a++) {
      rhs[a] = 0.0;
      for (int q = 0; q < n; q++) rhs[a] -= jac[q * nf + a] * r[q];
      for (int b = 0; b < nf; b++) {
        double acc = 0.0;
        for (int q = 0; q < n; q++) acc += jac[q * nf + a] * jac[q * nf + b];
        normal[a * nf + b] = acc;
      }
    }
    for (int a = 0; a < nf; a++) normal[a * nf + a] += damping * (normal[a * nf + a] + 1e-12);
    for (int a = 0; a < nf; a++) move[a] = rhs[a];
    if (!sk_solve(normal, move, nf)) break;
    double worst = 1.0;
    for (int a = 0; a < nf; a++) {
      double ratio = fabs(move[a] / MAX_MOVES[idx[a]]);
      if (ratio > worst) worst = ratio;
    }
    double largest = 0.0;
    for (int a = 0; a < nf; a++) {
      move[a] /= worst;
      if (fabs(move[a]) > largest) largest = fabs(move[a]);
    }
    memcpy(trial, u, sizeof trial);
    for (int a = 0; a < nf; a++) trial[idx[a]] += move[a];
    double cost2 = residuals(c, trial, r2);
    if (cost2 < cost) {
      memcpy(u, trial, sizeof trial);
      memcpy(r, r2, sizeof(double) * (size_t)n);
      memcpy(base, c->layer, sizeof(double) * (size_t)n);
      cost = cost2;
      damping *= 0.3;
      if (largest < 1e-4) break;
      stale = 1;
    } else {
      damping *= 10.0;
    }
  }
  return cost;
}

int sk_model_sub(const double *u) {
  double small = exp(u[LOG_RADIUS]) * fmin(exp(u[LOG_ASPECT]), 1.0);
  double s = ceil(12.0 / fmax(small, 1e-3));
  return (int)fmin(fmax(s, 24.0), 48.0);
}

void sk_model_steps(double *steps, double *max_moves, double *radius_scales) {
  memcpy(steps, STEPS, sizeof STEPS);
  memcpy(max_moves, MAX_MOVES, sizeof MAX_MOVES);
  memcpy(radius_scales, RADIUS_SCALES, sizeof RADIUS_SCALES);
}

static void free_ctx(fit_ctx *c) {
  for (int i = 0; i < 2; i++) {
    free(c->tabs[i].tab);
    free(c->tabs[i].kernel);
  }
  free(c->weights);
  free(c->fine);
  free(c->tmp);
  free(c->load);
  free(c->layer);
  free(c->axes);
}

/* The tip radius of least misfit among a few around u0's (a start's moments misread flat-topped
 * or stepped imprints, and a fit started at the wrong size stops on the film's cliffs): u0 with
 * it, to u; r is scratch for the residuals. */
static void best_radius(fit_ctx *c, const double *u0, double *r, double *u) {
  double least = INFINITY;
  memcpy(u, u0, sizeof(double) * NU);
  for (int s = 0; s < 6; s++) {
    double v[NU];
    memcpy(v, u0, sizeof v);
    v[LOG_RADIUS] += log(RADIUS_SCALES[s]);
    double cost = residuals(c, v, r);
    if (cost < least) {
      least = cost;
      memcpy(u, v, sizeof v);
    }
  }
}

/* A render's context of a rows x cols window at sub fine samples a taxel: 0, or -1 without
 * memory (free_ctx frees what was made either way). */
static int open_ctx(fit_ctx *c, const sk_taxel_model *model, int rows, int cols,
                    const double *counts, const unsigned char *censored,
                    const double *sensitivity, int sub) {
  memset(c, 0, sizeof *c);
  c->model = model;
  c->h = rows;
  c->w = cols;
  c->counts = counts;
  c->censored = censored;
  c->sensitivity = sensitivity;
  c->fill = model->fill_factor;
  c->turn_on = model->turn_on_pa * model->pitch_m * model->pitch_m;
  double cover = model->cover_spread_m / model->pitch_m;
  c->blur[0] = cover;
  c->blur[1] = hypot(cover, model->layer_spread_m / model->pitch_m);
  c->sub = sub;
  c->weights = malloc(sizeof(double) * (size_t)sub);
  c->layer = malloc(sizeof(double) * 2 * (size_t)rows * (size_t)cols);
  if (!c->weights || !c->layer) return -1;
  cell_weights(sub, c->fill, c->weights);
  for (int i = 0; i < 2; i++)
    if (build_tab(&c->tabs[i], c->weights, sub, c->blur[i] * sub)) return -1;
  return 0;
}

int sk_model_render(const sk_taxel_model *model, int rows, int cols, const double *u, int sub,
                    const double *sensitivity, double *counts_out) {
  fit_ctx c;
  int n = rows * cols, status = SK_ERR_NO_MEMORY;
  if (open_ctx(&c, model, rows, cols, NULL, NULL, sensitivity, sub > 0 ? sub : sk_model_sub(u))
      == 0) {
    render_layer(&c, u[X], u[Y], u, 0, c.layer);
    render_layer(&c, u[X] + u[DX], u[Y] + u[DY], u, 1, c.layer + n);
    for (int k = 0; k < 2 * n && !c.failed; k++)
      counts_out[k] = film_counts(model, c.layer[k] * (sensitivity ? sensitivity[k] : 1.0));
    status = c.failed ? SK_ERR_NO_MEMORY : SK_OK;
  }
  free_ctx(&c);
  return status;
}

int sk_model_residuals(const sk_taxel_model *model, int rows, int cols, const double *counts,
                       const unsigned char *censored, const double *sensitivity,
                       const double *u, int sub, double *r_out, double *misfit_out) {
  fit_ctx c;
  int status = SK_ERR_NO_MEMORY;
  if (open_ctx(&c, model, rows, cols, counts, censored, sensitivity,
               sub > 0 ? sub : sk_model_sub(u)) == 0) {
    double misfit = residuals(&c, u, r_out);
    if (!c.failed) {
      *misfit_out = misfit;
      status = SK_OK;
    }
  }
  free_ctx(&c);
  return status;
}

/* The best radius, then Levenberg-Marquardt over `free_`; with `ellipses`, then an elliptical
 * tip from four orientations, every parameter free, the least misfit kept. */
static int fit(const sk_taxel_model *model, int rows, int cols, const double *counts,
               const unsigned char *censored, const double *sensitivity, const double *u0,
               const int *free_, int iterations, int ellipses, double *u_out,
               double *misfit_out) {
  fit_ctx c;
  int n = 2 * rows * cols, status = SK_ERR_NO_MEMORY;
  double *work = malloc(sizeof(double) * (size_t)n * (4 + NU));  /* r r2 probe base jac */
  if (open_ctx(&c, model, rows, cols, counts, censored, sensitivity, sk_model_sub(u0)) || !work)
    goto done;
  double *r = work, *r2 = work + n, *probe = work + 2 * n, *base = work + 3 * n;
  double *jac = work + 4 * n;

  double u[NU], best_u[NU];
  best_radius(&c, u0, r, u);
  static const int EVERY[NU] = {1, 1, 1, 1, 1, 1, 1, 1};
  double best = levenberg_marquardt(&c, u, free_, iterations, r, r2, jac, probe, base);
  memcpy(best_u, u, sizeof u);
  for (int o = 0; ellipses && o < 4; o++) {
    double v[NU];
    memcpy(v, u, sizeof v);
    v[LOG_ASPECT] = log(0.8);
    v[ORIENTATION] = o * PI / 4;
    double cost = levenberg_marquardt(&c, v, EVERY, iterations, r, r2, jac, probe, base);
    if (cost < best) {
      best = cost;
      memcpy(best_u, v, sizeof v);
    }
  }
  if (c.failed) goto done;
  memcpy(u_out, best_u, sizeof best_u);
  *misfit_out = best;
  status = SK_OK;
done:
  free(work);
  free_ctx(&c);
  return status;
}

int sk_model_fit(const sk_taxel_model *model, int rows, int cols, const double *counts,
                 const unsigned char *censored, const double *sensitivity, const double *u0,
                 int iterations, double *u_out, double *misfit_out) {
  static const int ROUND[NU] = {1, 1, 1, 1, 1, 1, 0, 0};
  return fit(model, rows, cols, counts, censored, sensitivity, u0, ROUND, iterations, 1, u_out,
             misfit_out);
}

int sk_model_fit_free(const sk_taxel_model *model, int rows, int cols, const double *counts,
                      const unsigned char *censored, const double *sensitivity,
                      const double *u0, const int *free_, int iterations, double *u_out,
                      double *misfit_out) {
  return fit(model, rows, cols, counts, censored, sensitivity, u0, free_, iterations, 0, u_out,
             misfit_out);
}

/* The fit's start (taxelmodel.start_of): the top layer's centroid, its second moment less the
 * cover's blur and the pad's own (a Hertz disc's is a**2 / 5), the larger layer's force over the
 * pad's share; the shift is set by sk_model_refit. */
void sk_model_start(const sk_taxel_model *model, const double *force, int h, int w, double *start)
{
  int nn = h > w ? h : w;
  double *along = malloc(sizeof(double) * 2 * (size_t)nn);
  for (int j = 0; j < NU; j++) start[j] = 0.0;
  if (!along) {
    start[LOG_FORCE] = NAN;
    return;
  }
  double *along_x = along, *along_y = along + nn;
  sk_profiles_of(force, h, w, nn, along_x, along_y);
  double mass = sk_sum(force, h * w), sx = 0.0, sy = 0.0;
  for (int c = 0; c < w; c++) sx += along_x[c] * c;
  for (int r = 0; r < h; r++) sy += along_y[r] * r;
  double cx = sx / mass, cy = sy / mass, vx = 0.0, vy = 0.0;
  for (int c = 0; c < w; c++) vx += along_x[c] * ((c - cx) * (c - cx));
  for (int r = 0; r < h; r++) vy += along_y[r] * ((r - cy) * (r - cy));
  free(along);
  double var = (vx + vy) / (2.0 * mass);
  double cover = model->cover_spread_m / model->pitch_m;
  double radius = sqrt(5.0 * fmax(var - cover * cover - 1.0 / 12.0, 0.01));
  double top = mass, bottom = sk_sum(force + h * w, h * w);
  double fill = model->fill_factor;
  double load = (top > bottom ? top : bottom) / (fill * fill);
  start[X] = cx;
  start[Y] = cy;
  start[LOG_FORCE] = log(fmax(load, 1e-3));
  start[LOG_RADIUS] = log(fmin(fmax(radius, 0.1), 3.0));
}

/* model_fit's fit of one contact (shift.model_fit) from `start` and taxel_fit's (*dx, *dy). */
void sk_model_refit(const sk_taxel_model *model, const double *counts, const double *marks,
                    const double *sensitivity, int h, int w, double *start, double *dx,
                    double *dy)
{
  int n = 2 * h * w;
  unsigned char *censored = malloc((size_t)n);
  if (!censored) return;
  for (int i = 0; i < n; i++) censored[i] = marks[i] > 0.0;
  start[DX] = *dx;
  start[DY] = *dy;
  double u[NU], misfit;
  if (sk_model_fit(model, h, w, counts, censored, sensitivity, start, 10, u, &misfit) == 0) {
    *dx = u[DX];
    *dy = u[DY];
  }
  free(censored);
}
