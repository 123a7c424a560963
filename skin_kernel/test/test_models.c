/*
 * The models the calibration learns through the ABI, each written once in the kernel: the
 * direction correction's features, the creep law and the forward model of the taxels.
 */
#include <math.h>
#include <stdarg.h>
#include <setjmp.h>
#include <stddef.h>
#include <stdlib.h>

#include <cmocka.h>

#include "fixture.h"

/*
 * A contact a quarter taxel into its column, shifted a quarter taxel along x, pressing twice
 * the reference force: each feature's value, in the header's order.
 */
static void the_features_of_a_quarter_taxel_shift_are_the_header_s(void **state)
{
  (void)state;
  double col = 0.25, row = 0.0, dx = 0.25, dy = 0.0, normal = 20.0;
  double f[SK_DIRECTION_FEATURES];
  sk_direction_features(1, &col, &row, &dx, &dy, &normal, 10.0, f);
  const double expected[SK_DIRECTION_FEATURES] = {
    -1.0, -1.0, 0.0, 0.0,   /* h 1: sin, cos of the bottom's column phase less the top's; row */
    0.0, 2.0, 0.0, 0.0,     /* h 2 */
    1.0, 0.0, 0.0, 1.0,     /* the top's phase: h 1 column, row */
    0.0, -1.0, 0.0, 1.0,    /* h 2 */
    -1.0, -1.0, 0.0, 0.0};  /* the first four times the load over the reference, less 1 */
  for (int j = 0; j < SK_DIRECTION_FEATURES; j++) {
    assert_float_equal(f[j], expected[j], 1e-12);
  }
}

/* At the reference force the load features are 0; each contact's row is its own. */
static void each_contact_gets_its_own_row(void **state)
{
  (void)state;
  double col[3] = {0.1, 3.7, 5.0}, row[3] = {2.2, 0.4, 1.9}, dx[3] = {0.3, -0.2, 0.0};
  double dy[3] = {-0.1, 0.05, 0.6}, normal[3] = {4.0, 8.0, 2.0};
  double *all = malloc(sizeof(double) * 3 * SK_DIRECTION_FEATURES);
  double one[SK_DIRECTION_FEATURES];
  sk_direction_features(3, col, row, dx, dy, normal, 4.0, all);
  for (int i = 0; i < 3; i++) {
    sk_direction_features(1, col + i, row + i, dx + i, dy + i, normal + i, 4.0, one);
    assert_memory_equal(all + i * SK_DIRECTION_FEATURES, one, sizeof one);
  }
  for (int j = 16; j < SK_DIRECTION_FEATURES; j++) {
    assert_float_equal(all[j], 0.0, 0.0);
  }
  free(all);
}

/* No contact: nothing is written. */
static void no_contact_writes_nothing(void **state)
{
  (void)state;
  double out = 7.0;
  sk_direction_features(0, NULL, NULL, NULL, NULL, NULL, 1.0, &out);
  assert_float_equal(out, 7.0, 0.0);
}

/* The law's hard cases: a decade, two, no age, a negative age, no creep. */
static void the_creep_law_rises_by_its_rate_a_decade(void **state)
{
  (void)state;
  sk_drift d = {0.0, 0.03, 1.0, 0.0}, none = {0.0, 0.0, 1.0, 0.0};
  double ages[4] = {9.0, 99.0, 0.0, -5.0}, out[4];
  const double expected[4] = {1.03, 1.06, 1.0, 1.0};
  sk_creep(&d, 4, ages, 0, out);
  for (int i = 0; i < 4; i++) {
    assert_float_equal(out[i], expected[i], 1e-12);
  }
  double one = 1.0;
  sk_creep(&d, 1, &one, 1, out);
  assert_float_equal(out[0], 1.0, 1e-12);
  sk_creep(&none, 4, ages, 1, out);
  for (int i = 0; i < 4; i++) {
    assert_float_equal(out[i], 1.0, 0.0);
  }
}

/*
 * A press held still reads less as it ages, by the law's ratio: scans at 10, 15 and 20 s age it
 * 0, 5 and 10 s, and its force at 10 s over that at 5 s is the inverse of the law's.
 */
static void a_scan_divides_by_the_law_relative_to_1s(void **state)
{
  (void)state;
  spec s = spec_of(9, 9, SK_TAXEL_FIT);
  s.drift = 1;
  sk_settings st = settings_of(&s);
  sk_kernel *k = kernel_of(&s);
  sk_contact *out = records_for(&s);
  sk_status status;
  double *maps = rest_maps(9, 9);
  press(maps, 9, 9, 4, 4, 0.4, 0, 1500, 1.0);
  double force[3];
  for (int i = 0; i < 3; i++) {
    assert_int_equal(sk_scan(k, maps, 10.0 + 5.0 * i, 0, out, &status), 1);
    force[i] = out[0].force_n;
  }
  double ages[2] = {5.0, 10.0}, law[2];
  sk_creep(&st.drift, 2, ages, 1, law);
  assert_true(law[1] > law[0] && law[0] > 1.0);
  assert_float_equal(force[2] / force[1], law[0] / law[1], 1e-12);
  free(maps);
  free(out);
  sk_free(k);
}

/* A skin's taxel model: 5 mm pitch, 0.9 fill, 1 and 2 mm blurs, an activation of 0.01 N. */
static const sk_taxel_model MODEL = {0.005, 0.9, 0.001, 0.002, 0.67, 0.53, 3.3, 0.01, 0.0, 0.0,
                                     FULL_SCALE};

/* A round press u at (x, y) taxels of force_n, shifted (dx, dy), of radius radius taxels. */
static void press_at(double *u, double x, double y, double force_n, double dx, double dy,
                     double radius)
{
  double v[8] = {x, y, log(force_n), dx, dy, log(radius), 0.0, 0.0};
  for (int j = 0; j < 8; j++) {
    u[j] = v[j];
  }
}

/*
 * At a taxel's centre the maps are symmetric; lighter than one taxel's activation nothing reads;
 * a crushing press reads the film's resistance floor (full scale * ceiling / (1 + ceiling)).
 */
static void a_render_is_symmetric_silent_below_activation_and_floors(void **state)
{
  (void)state;
  enum { H = 12, W = 12, N = H * W };
  double u[8], *counts = malloc(sizeof(double) * 2 * N);
  press_at(u, 5.0, 6.0, 20.0, 0.0, 0.0, 0.8);
  assert_int_equal(sk_model_render(&MODEL, H, W, u, 24, NULL, counts), SK_OK);
  assert_true(counts[6 * W + 5] > 0.0);
  for (int layer = 0; layer < 2; layer++) {
    for (int r = 0; r < H; r++) {
      for (int d = 1; d <= 4; d++) {
        assert_float_equal(counts[layer * N + r * W + 5 - d], counts[layer * N + r * W + 5 + d],
                           1e-9);
      }
    }
  }
  press_at(u, 5.0, 6.0, 0.009, 0.0, 0.0, 0.8);
  assert_int_equal(sk_model_render(&MODEL, H, W, u, 0, NULL, counts), SK_OK);
  for (int i = 0; i < 2 * N; i++) {
    assert_float_equal(counts[i], 0.0, 0.0);
  }
  press_at(u, 5.0, 6.0, 1e7, 0.0, 0.0, 0.8);
  assert_int_equal(sk_model_render(&MODEL, H, W, u, 0, NULL, counts), SK_OK);
  assert_float_equal(counts[6 * W + 5], FULL_SCALE * 3.3 / 4.3, 1e-9);
  free(counts);
}

/*
 * The residuals of the model's own render are 0; a taxel read lower than the model is a
 * residual unless censored (a lower bound the model reads above).
 */
static void residuals_are_zero_on_the_model_s_render_and_censoring_is_one_sided(void **state)
{
  (void)state;
  enum { H = 9, W = 10, N = H * W };
  double u[8], misfit = -1.0;
  double *counts = malloc(sizeof(double) * 2 * N), *r = malloc(sizeof(double) * 2 * N);
  unsigned char *censored = calloc(2 * N, 1);
  press_at(u, 4.3, 4.6, 15.0, 0.4, -0.3, 0.9);
  assert_int_equal(sk_model_render(&MODEL, H, W, u, 0, NULL, counts), SK_OK);
  assert_int_equal(sk_model_residuals(&MODEL, H, W, counts, censored, NULL, u, 0, r, &misfit),
                   SK_OK);
  assert_float_equal(misfit, 0.0, 1e-18);
  int peak = 4 * W + 4;
  counts[peak] -= 100.0;
  assert_int_equal(sk_model_residuals(&MODEL, H, W, counts, censored, NULL, u, 0, r, &misfit),
                   SK_OK);
  assert_true(r[peak] > 0.0);
  assert_float_equal(misfit, r[peak] * r[peak], 1e-9);
  censored[peak] = 1;
  assert_int_equal(sk_model_residuals(&MODEL, H, W, counts, censored, NULL, u, 0, r, &misfit),
                   SK_OK);
  assert_float_equal(r[peak], 0.0, 0.0);
  free(counts);
  free(r);
  free(censored);
}

/* Fine samples: 24 for a taxel-wide tip, twelve over a narrow one's radius, at most 48. */
static void the_fine_samples_follow_the_tip_s_size(void **state)
{
  (void)state;
  double u[8];
  press_at(u, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0);
  assert_int_equal(sk_model_sub(u), 24);
  press_at(u, 0.0, 0.0, 1.0, 0.0, 0.0, 0.3);
  assert_int_equal(sk_model_sub(u), 40);
  press_at(u, 0.0, 0.0, 1.0, 0.0, 0.0, 0.1);
  assert_int_equal(sk_model_sub(u), 48);
}

/* A start from a render finds its centre; the fit's numbers are the fit's. */
static void a_start_finds_a_render_s_centre(void **state)
{
  (void)state;
  enum { H = 11, W = 11, N = H * W };
  double u[8], start[8], *counts = malloc(sizeof(double) * 2 * N);
  press_at(u, 5.0, 4.0, 10.0, 0.0, 0.0, 1.0);
  assert_int_equal(sk_model_render(&MODEL, H, W, u, 0, NULL, counts), SK_OK);
  sk_model_start(&MODEL, counts, H, W, start);
  assert_float_equal(start[0], 5.0, 1e-9);
  assert_float_equal(start[1], 4.0, 1e-9);
  assert_float_equal(start[3], 0.0, 0.0);
  double steps[8], moves[8], scales[6];
  sk_model_steps(steps, moves, scales);
  for (int j = 0; j < 8; j++) {
    assert_true(steps[j] > 0.0 && moves[j] > steps[j]);
  }
  assert_float_equal(scales[3], 1.0, 0.0);
  free(counts);
}

/*
 * A fit that holds the force: from a start off by a third of a taxel and a tip 60 % too wide it
 * finds the rendered press, its force and ellipse left as they were.
 */
static void a_fit_with_the_force_held_finds_the_press_and_keeps_the_force(void **state)
{
  (void)state;
  enum { H = 10, W = 10, N = H * W };
  double truth[8], start[8], u[8], misfit = -1.0, *counts = malloc(sizeof(double) * 2 * N);
  press_at(truth, 4.4, 5.2, 12.0, 0.6, -0.4, 0.9);
  assert_int_equal(sk_model_render(&MODEL, H, W, truth, 0, NULL, counts), SK_OK);
  press_at(start, 4.1, 5.5, 12.0, 0.3, -0.1, 1.45);
  static const int HELD_FORCE[8] = {1, 1, 0, 1, 1, 1, 0, 0};
  assert_int_equal(sk_model_fit_free(&MODEL, H, W, counts, NULL, NULL, start, HELD_FORCE, 30,
                                     u, &misfit), SK_OK);
  for (int j = 0; j < 8; j++) {
    assert_float_equal(u[j], truth[j], 2e-3);
  }
  assert_float_equal(u[2], start[2], 0.0);
  assert_float_equal(u[6], 0.0, 0.0);
  assert_true(misfit < 1e-2);
  free(counts);
}

int main(void)
{
  const struct CMUnitTest tests[] = {
    cmocka_unit_test(the_features_of_a_quarter_taxel_shift_are_the_header_s),
    cmocka_unit_test(each_contact_gets_its_own_row),
    cmocka_unit_test(no_contact_writes_nothing),
    cmocka_unit_test(the_creep_law_rises_by_its_rate_a_decade),
    cmocka_unit_test(a_scan_divides_by_the_law_relative_to_1s),
    cmocka_unit_test(a_render_is_symmetric_silent_below_activation_and_floors),
    cmocka_unit_test(residuals_are_zero_on_the_model_s_render_and_censoring_is_one_sided),
    cmocka_unit_test(the_fine_samples_follow_the_tip_s_size),
    cmocka_unit_test(a_start_finds_a_render_s_centre),
    cmocka_unit_test(a_fit_with_the_force_held_finds_the_press_and_keeps_the_force),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
