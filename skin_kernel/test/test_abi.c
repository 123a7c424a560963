/* The ABI's entry points: the layout table, sk_new's refusals, and the calls besides a scan. */
#include <math.h>
#include <stdarg.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "fixture.h"

static void the_version_is_the_header_s(void **state)
{
  (void)state;
  const sk_field *fields = NULL;
  int abi = -1;
  int count = sk_layout(&fields, &abi);
  assert_int_equal(sk_abi_version(), SK_ABI_VERSION);
  assert_int_equal(abi, SK_ABI_VERSION);
  assert_true(count > 0);
  assert_non_null(fields);
}

/* Every field of the layout table lies inside the struct it names, whose size is its own. */
static void the_layout_names_every_struct_s_fields_inside_it(void **state)
{
  (void)state;
  const sk_field *fields = NULL;
  int abi = 0, count = sk_layout(&fields, &abi);
  struct { const char *type; unsigned long size; } sizes[] = {
    {"sk_taxel_model", sizeof(sk_taxel_model)}, {"sk_curve", sizeof(sk_curve)},
    {"sk_settings", sizeof(sk_settings)}, {"sk_direction", sizeof(sk_direction)},
    {"sk_drift", sizeof(sk_drift)}, {"sk_contact", sizeof(sk_contact)},
    {"sk_status", sizeof(sk_status)}};
  int own_sizes = 0;
  for (int i = 0; i < count; i++) {
    unsigned long size = 0;
    for (size_t t = 0; t < sizeof sizes / sizeof sizes[0]; t++) {
      if (strcmp(fields[i].type, sizes[t].type) == 0) {
        size = sizes[t].size;
      }
    }
    assert_true(size > 0);
    if (fields[i].field == NULL) {
      assert_int_equal(fields[i].size, size);
      own_sizes++;
    } else {
      assert_true(fields[i].size > 0);
      assert_true(fields[i].offset + fields[i].size <= size);
    }
  }
  assert_int_equal(own_sizes, (int)(sizeof sizes / sizeof sizes[0]));
}

/* Each unusable setting is refused with a message naming it, and no kernel. */
static void unusable_settings_are_refused_by_name(void **state)
{
  (void)state;
  spec s = spec_of(4, 4, SK_TAXEL_FIT);
  struct { const char *expected; sk_settings st; } cases[8];
  for (int i = 0; i < 8; i++) {
    cases[i].st = settings_of(&s);
  }
  cases[0].expected = "maps of 0 x 4 taxels";
  cases[0].st.rows = 0;
  cases[1].expected = "maps of 4 x 4097 taxels";
  cases[1].st.cols = 4097;
  cases[2].expected = "full scale 0 counts";
  cases[2].st.full_scale = 0;
  cases[3].expected = "max_contacts -1";
  cases[3].st.max_contacts = -1;
  cases[4].expected = "unknown shift method 4";
  cases[4].st.method = SK_NMETHODS;
  cases[5].expected = "pitch, fill factor and compliance must be positive";
  cases[5].st.pitch_m = NAN;
  cases[6].expected = "the direction correction needs a positive reference force";
  cases[6].st.direction.on = 1;
  cases[7].expected = "drift:";
  cases[7].st.drift.track_s = -1.0;
  for (int i = 0; i < 8; i++) {
    char message[200];
    assert_int_equal(try_settings(&cases[i].st, sizeof(sk_settings), message, sizeof message),
                     SK_ERR_SETTINGS);
    if (strstr(message, cases[i].expected) == NULL) {
      fail_msg("case %d: \"%s\" does not say \"%s\"", i, message, cases[i].expected);
    }
  }
}

static void settings_of_another_size_are_refused(void **state)
{
  (void)state;
  spec s = spec_of(4, 4, SK_CENTROID);
  sk_settings st = settings_of(&s);
  char message[200];
  assert_int_equal(try_settings(&st, sizeof st - 8, message, sizeof message), SK_ERR_SETTINGS);
  assert_non_null(strstr(message, "settings of"));
}

/* A message longer than its buffer is cut there, NUL-terminated; a size of 0 writes nothing. */
static void a_refusal_s_message_stays_in_its_buffer(void **state)
{
  (void)state;
  spec s = spec_of(4, 4, SK_CENTROID);
  sk_settings st = settings_of(&s);
  st.rows = -3;
  char *small = malloc(5);
  assert_int_equal(try_settings(&st, sizeof st, small, 5), SK_ERR_SETTINGS);
  assert_string_equal(small, "maps");
  free(small);
  assert_int_equal(try_settings(&st, sizeof st, NULL, 0), SK_ERR_SETTINGS);
}

static void freeing_no_kernel_does_nothing(void **state)
{
  (void)state;
  sk_free(NULL);
}

/* sk_force: a count at or below 0 has no force, a clipped taxel reads full scale's. */
static void force_reads_the_tables(void **state)
{
  (void)state;
  spec s = spec_of(2, 3, SK_CENTROID);
  sk_kernel *k = kernel_of(&s);
  double counts[12] = {0, -5, 10, 1000, 20, 30, 0, 0, 0, 0, 0, 50};
  unsigned char clipped[12] = {0};
  clipped[5] = 1;
  double force[12];
  assert_int_equal(sk_force(k, counts, clipped, force), SK_OK);
  assert_true(force[0] == 0.0);
  assert_true(force[1] == 0.0);
  assert_float_equal(force[2], 10 * NEWTONS_PER_COUNT, 1e-12);
  assert_float_equal(force[3], 1000 * NEWTONS_PER_COUNT, 1e-12);
  assert_float_equal(force[5], FULL_SCALE * NEWTONS_PER_COUNT, 1e-12);
  assert_float_equal(force[11], 50 * NEWTONS_PER_COUNT, 1e-12);
  counts[7] = NAN;
  assert_int_equal(sk_force(k, counts, NULL, force), SK_ERR_NOT_FINITE);
  sk_free(k);
}

/* sk_condition's outputs are each optional; the tared counts are the raw less the rest. */
static void conditioning_writes_what_is_asked(void **state)
{
  (void)state;
  spec s = spec_of(8, 8, SK_TAXEL_FIT);
  sk_kernel *k = kernel_of(&s);
  double *maps = rest_maps(8, 8);
  maps[3 * 8 + 4] = REST + 500;
  maps[64 + 3 * 8 + 4] = FULL_SCALE;
  double *counts = malloc(sizeof(double) * 128), *force = malloc(sizeof(double) * 128);
  unsigned char *clipped = malloc(128);
  double *leak = malloc(sizeof(double) * 2 * (8 + 8));
  assert_int_equal(sk_condition(k, maps, counts, force, clipped, leak), SK_OK);
  assert_true(counts[3 * 8 + 4] > 0);
  assert_true(counts[0] == 0.0);
  assert_int_equal(clipped[64 + 3 * 8 + 4], 1);
  assert_int_equal(clipped[3 * 8 + 4], 0);
  assert_true(force[64 + 3 * 8 + 4] > force[3 * 8 + 4]);
  assert_int_equal(sk_condition(k, maps, NULL, NULL, NULL, NULL), SK_OK);
  maps[5] = -1;
  assert_int_equal(sk_condition(k, maps, counts, NULL, NULL, NULL), SK_ERR_NEGATIVE);
  free(maps);
  free(counts);
  free(force);
  free(clipped);
  free(leak);
  sk_free(k);
}

/*
 * sk_carry puts the per-scan state in force in a kernel built before it changed: a mark revived
 * and a drift followed after the build are kept, and the two kernels scan alike from then on.
 */
static void the_per_scan_state_is_carried_whole(void **state)
{
  (void)state;
  int rows = 5, cols = 7, n = rows * cols, t = 2 * cols + 3;
  unsigned char *dead = calloc(2 * (size_t)n, 1), *marks = malloc(2 * (size_t)n);
  dead[t] = 1;
  spec s = spec_of(rows, cols, SK_CENTROID);
  s.drift = 1;
  s.dead = dead;
  sk_kernel *k = kernel_of(&s), *built = kernel_of(&s);
  double *maps = rest_maps(rows, cols);
  press(maps, rows, cols, 2, 3, 0, 0, 800, 1.0);
  for (int i = 0; i < 2 * n; i++) {
    maps[i] += i % 3;   /* a drift to follow */
  }
  sk_contact *out = records_for(&s), *out_built = records_for(&s);
  sk_status status, status_built;
  assert_true(sk_scan(k, maps, 0.0, 0, out, &status) >= 1);
  assert_int_equal(status.revived, 1);
  assert_true(sk_scan(k, maps, 2.0, 0, out, &status) >= 1);
  sk_dead(built, marks);
  assert_int_equal(marks[t], 1);   /* built before the scans revived it */

  assert_int_equal(sk_carry(built, k), SK_OK);
  sk_dead(built, marks);
  assert_int_equal(marks[t], 0);
  int found = sk_scan(k, maps, 3.0, 0, out, &status);
  assert_int_equal(sk_scan(built, maps, 3.0, 0, out_built, &status_built), found);
  assert_memory_equal(out, out_built, sizeof(sk_contact) * (size_t)found);
  assert_memory_equal(status.drift_mean, status_built.drift_mean, sizeof status.drift_mean);
  assert_memory_equal(status.drift_max, status_built.drift_max, sizeof status.drift_max);
  assert_int_equal(sk_carry(k, k), SK_OK);

  /* a kernel of another grid is refused */
  spec wide = spec_of(rows, cols + 1, SK_CENTROID);
  wide.drift = 1;
  sk_kernel *other = kernel_of(&wide);
  assert_int_equal(sk_carry(other, k), SK_ERR_SETTINGS);
  free(dead);
  free(marks);
  free(maps);
  free(out);
  free(out_built);
  sk_free(k);
  sk_free(built);
  sk_free(other);
}

int main(void)
{
  const struct CMUnitTest tests[] = {
    cmocka_unit_test(the_version_is_the_header_s),
    cmocka_unit_test(the_layout_names_every_struct_s_fields_inside_it),
    cmocka_unit_test(unusable_settings_are_refused_by_name),
    cmocka_unit_test(settings_of_another_size_are_refused),
    cmocka_unit_test(a_refusal_s_message_stays_in_its_buffer),
    cmocka_unit_test(freeing_no_kernel_does_nothing),
    cmocka_unit_test(force_reads_the_tables),
    cmocka_unit_test(conditioning_writes_what_is_asked),
    cmocka_unit_test(the_per_scan_state_is_carried_whole),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
