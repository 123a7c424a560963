/*
 * Scans at the hard cases and at the limits the scratch buffers are sized for (kernel.c's
 * formulas): the whole grid one contact, as many contacts as taxels allow, a single taxel, the
 * longest line, every taxel saturated, dead taxels; each shift method, model_fit included.
 */
#include <math.h>
#include <stdarg.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "fixture.h"

static const int methods[] = {SK_CENTROID, SK_TAXEL_FIT, SK_POC, SK_MODEL_FIT};
#define NMETHODS ((int)(sizeof methods / sizeof methods[0]))

/* Every figure of a record is a number (inf only for a sigma). */
static void assert_records_finite(const sk_contact *out, int count)
{
  for (int i = 0; i < count; i++) {
    const sk_contact *c = &out[i];
    double figures[] = {c->x_m, c->y_m, c->force_n, c->area_m2, c->shift_x_m, c->shift_y_m,
                        c->azimuth_rad, c->azimuth_sigma_rad, c->alpha_rad, c->force_x_n,
                        c->force_y_n, c->force_z_n, c->confidence, c->dx, c->dy,
                        c->top_force_n, c->bottom_force_n, c->shift_confidence, c->held_s};
    for (size_t j = 0; j < sizeof figures / sizeof figures[0]; j++) {
      if (!isfinite(figures[j])) {
        fail_msg("record %d, figure %zu is %g", i, j, figures[j]);
      }
    }
    assert_false(isnan(c->sigma));
  }
}

/* One scan of maps by a kernel of the spec: the count of records (checked finite). */
static int scan_of(const spec *s, const double *maps, sk_status *status)
{
  sk_kernel *k = kernel_of(s);
  sk_contact *out = records_for(s);
  int count = sk_scan(k, maps, NAN, 1, out, status);
  assert_true(count >= 0);
  assert_records_finite(out, count);
  free(out);
  sk_free(k);
  return count;
}

static void an_empty_frame_has_no_contact(void **state)
{
  (void)state;
  for (int m = 0; m < NMETHODS; m++) {
    spec s = spec_of(8, 12, methods[m]);
    double *maps = rest_maps(8, 12);
    sk_status status;
    assert_int_equal(scan_of(&s, maps, &status), 0);
    assert_int_equal(status.found, 0);
    assert_int_equal(status.censored, 0);
    free(maps);
  }
}

/* A value that is not a count is refused, and the kernel scans on as before. */
static void maps_that_are_not_counts_are_refused(void **state)
{
  (void)state;
  spec s = spec_of(6, 6, SK_TAXEL_FIT);
  sk_kernel *k = kernel_of(&s);
  sk_contact *out = records_for(&s);
  sk_status status;
  double *maps = rest_maps(6, 6);
  press(maps, 6, 6, 3, 3, 0.5, 0, 1500, 1.0);
  int before = sk_scan(k, maps, NAN, 0, out, &status);
  assert_int_equal(before, 1);
  double saved = maps[40];
  double bad[] = {NAN, INFINITY, -1.0};
  int expected[] = {SK_ERR_NOT_FINITE, SK_ERR_NOT_FINITE, SK_ERR_NEGATIVE};
  for (int i = 0; i < 3; i++) {
    maps[40] = bad[i];
    assert_int_equal(sk_scan(k, maps, NAN, 0, out, &status), expected[i]);
    assert_int_equal(sk_scan_shifted(k, maps, 0, NULL, NULL, out, &status), expected[i]);
  }
  maps[40] = saved;
  assert_int_equal(sk_scan(k, maps, NAN, 0, out, &status), before);
  free(maps);
  free(out);
  sk_free(k);
}

/* sk_scan_counts is sk_scan of the same counts, to the bit. */
static void adc_counts_scan_as_doubles_do(void **state)
{
  (void)state;
  spec s = spec_of(10, 9, SK_TAXEL_FIT);
  sk_kernel *a = kernel_of(&s), *b = kernel_of(&s);
  double *maps = rest_maps(10, 9);
  press(maps, 10, 9, 4.3, 5.1, 0.6, -0.4, 2000, 1.2);
  uint16_t *counts = malloc(sizeof(uint16_t) * 2 * 90);
  for (int i = 0; i < 180; i++) {
    counts[i] = (uint16_t)maps[i];
  }
  sk_contact *x = records_for(&s), *y = records_for(&s);
  sk_status sx, sy;
  int nx = sk_scan(a, maps, 1.0, 0, x, &sx), ny = sk_scan_counts(b, counts, 1.0, 0, y, &sy);
  assert_int_equal(nx, 1);
  assert_int_equal(ny, nx);
  assert_memory_equal(x, y, sizeof(sk_contact) * (size_t)nx);
  free(maps);
  free(counts);
  free(x);
  free(y);
  sk_free(a);
  sk_free(b);
}

/* Each method finds a shift of one taxel along the columns (the bottom's) to its sign. */
static void every_method_finds_the_shift_s_direction(void **state)
{
  (void)state;
  for (int m = 0; m < NMETHODS; m++) {
    spec s = spec_of(16, 16, methods[m]);
    sk_kernel *k = kernel_of(&s);
    sk_contact *out = records_for(&s);
    sk_status status;
    double *maps = rest_maps(16, 16);
    press(maps, 16, 16, 7.5, 7.5, 1.0, 0.0, 1500, 1.5);
    assert_int_equal(sk_scan(k, maps, NAN, 0, out, &status), 1);
    assert_records_finite(out, 1);
    if (!(out[0].dx > 0.5 && out[0].dx < 1.5 && fabs(out[0].dy) < 0.3)) {
      fail_msg("method %d: shift (%g, %g) taxels, not about (1, 0)", methods[m], out[0].dx,
               out[0].dy);
    }
    free(maps);
    free(out);
    sk_free(k);
  }
}

/*
 * A 1 x 1 skin: one taxel pressed is one contact at its centre with no direction. The fits find
 * no shift; model_fit's refit of a window of one taxel a layer is free to move a little (its
 * render of the shifted bottom matches one count as well), never as far as a direction.
 */
static void a_single_taxel_is_one_contact(void **state)
{
  (void)state;
  for (int m = 0; m < NMETHODS; m++) {
    spec s = spec_of(1, 1, methods[m]);
    double maps[2] = {REST + 800, REST + 800};
    sk_kernel *k = kernel_of(&s);
    sk_contact out[1];
    sk_status status;
    assert_int_equal(sk_scan(k, maps, NAN, 1, out, &status), 1);
    assert_records_finite(out, 1);
    assert_float_equal(out[0].x_m, 0.0, 1e-12);
    double most = methods[m] == SK_MODEL_FIT ? 0.1 : 1e-9;
    assert_int_equal(out[0].valid, 0);
    if (!(fabs(out[0].dx) < most && fabs(out[0].dy) < most)) {
      fail_msg("method %d: shift (%g, %g) on one taxel", methods[m], out[0].dx, out[0].dy);
    }
    assert_true(out[0].force_n > 0);
    sk_free(k);
  }
}

/* The callback's shift is the record's; a callback that gives none leaves a shift of 0. */
static int given_shift(void *user, const double *window, int h, int w, double *shift)
{
  int *calls = user;
  assert_true(h >= 1 && w >= 1);
  /* the whole (2, h, w) window is readable */
  double sum = 0.0;
  for (int i = 0; i < 2 * h * w; i++) {
    sum += window[i];
  }
  assert_true(sum > 0);
  shift[0] = 0.75;
  shift[1] = -0.25;
  shift[2] = 0.5;
  return (*calls)++ > 0;
}

static void a_given_shift_is_the_record_s(void **state)
{
  (void)state;
  spec s = spec_of(12, 12, SK_CENTROID);
  sk_kernel *k = kernel_of(&s);
  sk_contact *out = records_for(&s);
  sk_status status;
  double *maps = rest_maps(12, 12);
  press(maps, 12, 12, 5, 5, 0, 0, 1500, 1.0);
  int calls = 0;
  assert_int_equal(sk_scan_shifted(k, maps, 0, given_shift, &calls, out, &status), 1);
  assert_float_equal(out[0].dx, 0.75, 0.0);
  assert_float_equal(out[0].dy, -0.25, 0.0);
  assert_float_equal(out[0].shift_confidence, 0.5, 0.0);
  assert_int_equal(sk_scan_shifted(k, maps, 0, given_shift, &calls, out, &status), 1);
  assert_float_equal(out[0].dx, 0.0, 0.0);
  assert_float_equal(out[0].dy, 0.0, 0.0);
  assert_int_equal(calls, 2);
  free(maps);
  free(out);
  sk_free(k);
}

/*
 * Every taxel at the ADC's full scale on both layers: one contact, the whole grid its window,
 * censored on both layers, each method (the largest window each shift's scratch must hold).
 */
static void a_saturated_frame_is_one_censored_contact(void **state)
{
  (void)state;
  int sizes[][2] = {{1, 1}, {3, 3}, {8, 8}, {2, 40}, {40, 2}};
  for (size_t g = 0; g < sizeof sizes / sizeof sizes[0]; g++) {
    int rows = sizes[g][0], cols = sizes[g][1], n = rows * cols;
    for (int m = 0; m < NMETHODS; m++) {
      spec s = spec_of(rows, cols, methods[m]);
      s.censor = 3000;
      double *maps = rest_maps(rows, cols);
      for (int i = 0; i < 2 * n; i++) {
        maps[i] = FULL_SCALE;
      }
      sk_status status;
      assert_int_equal(scan_of(&s, maps, &status), 1);
      assert_int_equal(status.censored, 3);
      free(maps);
    }
  }
}

/*
 * A broad press that saturates its middle and fills the grid: the censored fits (taxel_fit's,
 * and model_fit's start from it) run on a window of every taxel.
 */
static void a_saturated_press_filling_the_grid_is_fitted(void **state)
{
  (void)state;
  int sizes[][2] = {{6, 6}, {12, 12}, {5, 17}, {17, 5}};
  for (size_t g = 0; g < sizeof sizes / sizeof sizes[0]; g++) {
    int rows = sizes[g][0], cols = sizes[g][1];
    for (int m = 0; m < NMETHODS; m++) {
      spec s = spec_of(rows, cols, methods[m]);
      s.censor = 3000;
      double *maps = rest_maps(rows, cols);
      press(maps, rows, cols, 0.5 * (rows - 1), 0.5 * (cols - 1), 0.3, 0.2, 12000,
            0.3 * (rows > cols ? rows : cols));
      sk_status status;
      assert_int_equal(scan_of(&s, maps, &status), 1);
      assert_int_equal(status.censored, 3);
      free(maps);
    }
  }
}

/*
 * As many contacts as the grid can hold apart (a taxel pressed in every other row and column),
 * with max_contacts the number of taxels: every contact reported, each its own record.
 */
static void the_most_contacts_a_grid_holds_are_each_reported(void **state)
{
  (void)state;
  int rows = 9, cols = 11, n = rows * cols;
  for (int m = 0; m < NMETHODS; m++) {
    spec s = spec_of(rows, cols, methods[m]);
    s.max_contacts = n;
    s.censor = 3000;
    double *maps = rest_maps(rows, cols);
    int pressed = 0;
    for (int r = 0; r < rows; r += 2) {
      for (int c = 0; c < cols; c += 2) {
        maps[r * cols + c] = maps[n + r * cols + c] = (pressed % 3 == 0) ? FULL_SCALE : 1500;
        pressed++;
      }
    }
    sk_status status;
    assert_int_equal(scan_of(&s, maps, &status), pressed);
    assert_int_equal(status.found, pressed);
    free(maps);
  }
}

/* More contacts than max_contacts: the kernel keeps as many as it may; 0 keeps none. */
static void contacts_past_max_contacts_are_not_written(void **state)
{
  (void)state;
  int rows = 8, cols = 8, n = rows * cols;
  for (int most = 0; most <= 3; most += 3) {
    spec s = spec_of(rows, cols, SK_TAXEL_FIT);
    s.max_contacts = most;
    double *maps = rest_maps(rows, cols);
    for (int r = 0; r < rows; r += 2) {
      for (int c = 0; c < cols; c += 2) {
        maps[r * cols + c] = maps[n + r * cols + c] = 1500;
      }
    }
    sk_status status;
    int count = scan_of(&s, maps, &status);
    assert_true(count <= most);
    free(maps);
  }
}

/* The longest line sk_new takes (4096 taxels), either way round; one longer is refused. */
static void the_longest_line_is_scanned(void **state)
{
  (void)state;
  int shapes[][2] = {{1, 4096}, {4096, 1}};
  for (int g = 0; g < 2; g++) {
    int rows = shapes[g][0], cols = shapes[g][1];
    for (int m = 0; m < NMETHODS; m++) {
      spec s = spec_of(rows, cols, methods[m]);
      double *maps = rest_maps(rows, cols);
      int n = rows * cols;
      /* a press at each end and one in the middle */
      int at[] = {0, n / 2, n - 1};
      for (int i = 0; i < 3; i++) {
        for (int d = -2; d <= 2; d++) {
          int j = at[i] + d;
          if (j >= 0 && j < n) {
            maps[j] = maps[n + j] = REST + 1500 - 400 * abs(d);
          }
        }
      }
      sk_status status;
      assert_int_equal(scan_of(&s, maps, &status), 3);
      free(maps);
    }
    spec s = spec_of(rows == 1 ? 1 : 4097, cols == 1 ? 1 : 4097, SK_CENTROID);
    sk_settings st = settings_of(&s);
    char message[200];
    assert_int_equal(try_settings(&st, sizeof st, message, sizeof message), SK_ERR_SETTINGS);
  }
}

/*
 * The firmware's largest grid, 128 x 128: a light press and a broad saturated one, each method
 * (a window of the whole grid is the smaller grids' case above: model_fit's render of one this
 * large takes seconds under the sanitizers).
 */
static void the_largest_board_grid_is_scanned(void **state)
{
  (void)state;
  int rows = 128, cols = 128;
  for (int m = 0; m < NMETHODS; m++) {
    spec s = spec_of(rows, cols, methods[m]);
    s.censor = 3000;
    double *maps = rest_maps(rows, cols);
    press(maps, rows, cols, 20.0, 100.0, 0.5, 0.5, 3000, 1.5);
    press(maps, rows, cols, 90.0, 40.0, 0.5, -0.5, 20000, 5.0);
    sk_status status;
    int count = scan_of(&s, maps, &status);
    assert_true(count >= 1);
    assert_int_equal(status.censored, 3);
    free(maps);
  }
}

/*
 * Dead taxels: one inside a press is filled from its live neighbours (fill_dead) or reads 0
 * (without); one that reads a touch is revived. A skin of dead taxels only finds nothing.
 */
static void dead_taxels_are_filled_and_revived(void **state)
{
  (void)state;
  int rows = 7, cols = 7, n = rows * cols, centre = 3 * cols + 3;
  unsigned char *dead = calloc(2 * (size_t)n, 1);
  dead[centre] = 1;
  for (int fill = 0; fill <= 1; fill++) {
    spec s = spec_of(rows, cols, SK_TAXEL_FIT);
    s.fill_dead = fill;
    s.dead = dead;
    sk_kernel *k = kernel_of(&s);
    double *maps = rest_maps(rows, cols);
    press(maps, rows, cols, 3, 3, 0, 0, 1000, 1.0);
    maps[centre] = 0;   /* a dead taxel rests below zero */
    double *counts = malloc(sizeof(double) * 2 * (size_t)n);
    assert_int_equal(sk_condition(k, maps, counts, NULL, NULL, NULL), SK_OK);
    if (fill) {
      double ring = 0.0;
      for (int dr = -1; dr <= 1; dr++) {
        for (int dc = -1; dc <= 1; dc++) {
          ring += (dr || dc) ? counts[centre + dr * cols + dc] : 0.0;
        }
      }
      assert_float_equal(counts[centre], ring / 8.0, 1e-9);
    } else {
      assert_float_equal(counts[centre], 0.0, 0.0);
    }
    unsigned char *marks = malloc(2 * (size_t)n);
    sk_dead(k, marks);
    assert_int_equal(marks[centre], 1);
    maps[centre] = REST + 1000;   /* it reads a touch: alive after all */
    sk_contact *out = records_for(&s);
    sk_status status;
    assert_int_equal(sk_scan(k, maps, NAN, 0, out, &status), 1);
    assert_int_equal(status.revived, 1);
    sk_dead(k, marks);
    assert_int_equal(marks[centre], 0);
    free(marks);
    free(out);
    free(counts);
    free(maps);
    sk_free(k);
  }
  memset(dead, 1, 2 * (size_t)n);
  for (int m = 0; m < NMETHODS; m++) {
    spec s = spec_of(rows, cols, methods[m]);
    s.dead = dead;
    double *maps = rest_maps(rows, cols);
    for (int i = 0; i < 2 * n; i++) {
      maps[i] = 0;
    }
    sk_status status;
    assert_int_equal(scan_of(&s, maps, &status), 0);
    free(maps);
  }
  free(dead);
}

/* Scans given their time age a held press; a press held 5 s is older than its first scan. */
static void a_held_press_ages(void **state)
{
  (void)state;
  spec s = spec_of(9, 9, SK_TAXEL_FIT);
  s.drift = 1;
  sk_kernel *k = kernel_of(&s);
  sk_contact *out = records_for(&s);
  sk_status status;
  double *maps = rest_maps(9, 9);
  press(maps, 9, 9, 4, 4, 0.4, 0, 1500, 1.0);
  assert_int_equal(sk_scan(k, maps, 10.0, 0, out, &status), 1);
  double first = out[0].held_s;
  assert_int_equal(sk_scan(k, maps, 15.0, 0, out, &status), 1);
  assert_float_equal(out[0].held_s, first + 5.0, 1e-9);
  free(maps);
  free(out);
  sk_free(k);
}

/* sk_model_fit on a window alone: from its start it settles to a finite press and misfit. */
static void the_model_fits_a_window_alone(void **state)
{
  (void)state;
  spec s = spec_of(1, 1, SK_MODEL_FIT);
  sk_settings st = settings_of(&s);
  int shapes[][2] = {{1, 1}, {5, 5}, {3, 9}};
  for (int g = 0; g < 3; g++) {
    int rows = shapes[g][0], cols = shapes[g][1], n = rows * cols;
    double *counts = malloc(sizeof(double) * 2 * (size_t)n);
    unsigned char *censored = calloc(2 * (size_t)n, 1);
    for (int i = 0; i < 2 * n; i++) {
      counts[i] = 300.0 + 50.0 * (i % n == n / 2);
    }
    censored[n / 2] = 1;
    double u0[8] = {0.5 * (cols - 1), 0.5 * (rows - 1), log(2.0), 0.2, 0.0, log(0.8), 0.0, 0.0};
    double u[8], misfit = NAN;
    for (int iterations = 0; iterations <= 3; iterations += 3) {
      assert_int_equal(sk_model_fit(&st.model, rows, cols, counts, censored, NULL, u0,
                                    iterations, u, &misfit), SK_OK);
      for (int j = 0; j < 8; j++) {
        assert_true(isfinite(u[j]));
      }
      assert_true(isfinite(misfit) && misfit >= 0);
    }
    free(counts);
    free(censored);
  }
}

int main(void)
{
  const struct CMUnitTest tests[] = {
    cmocka_unit_test(an_empty_frame_has_no_contact),
    cmocka_unit_test(maps_that_are_not_counts_are_refused),
    cmocka_unit_test(adc_counts_scan_as_doubles_do),
    cmocka_unit_test(every_method_finds_the_shift_s_direction),
    cmocka_unit_test(a_single_taxel_is_one_contact),
    cmocka_unit_test(a_given_shift_is_the_record_s),
    cmocka_unit_test(a_saturated_frame_is_one_censored_contact),
    cmocka_unit_test(a_saturated_press_filling_the_grid_is_fitted),
    cmocka_unit_test(the_most_contacts_a_grid_holds_are_each_reported),
    cmocka_unit_test(contacts_past_max_contacts_are_not_written),
    cmocka_unit_test(the_longest_line_is_scanned),
    cmocka_unit_test(the_largest_board_grid_is_scanned),
    cmocka_unit_test(dead_taxels_are_filled_and_revived),
    cmocka_unit_test(a_held_press_ages),
    cmocka_unit_test(the_model_fits_a_window_alone),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
