/*
 * The models the calibration learns through the ABI, each written once in the kernel: the
 * direction correction's features.
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

int main(void)
{
  const struct CMUnitTest tests[] = {
    cmocka_unit_test(the_features_of_a_quarter_taxel_shift_are_the_header_s),
    cmocka_unit_test(each_contact_gets_its_own_row),
    cmocka_unit_test(no_contact_writes_nothing),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
