/* The 64-bit device time across wraps of the 32-bit board clock. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "skin_fw/clock.h"

static void no_wrap_keeps_the_reading(void **state) {
  (void)state;
  skin_clock_t c;
  skin_clock_init(&c, 100u);
  assert_true(skin_clock_extend(&c, 100u) == 100u);
  assert_true(skin_clock_extend(&c, 5000u) == 5000u);
}

static void wrap_carries_into_the_high_word(void **state) {
  (void)state;
  skin_clock_t c;
  skin_clock_init(&c, 0xFFFFFF00u);
  assert_true(skin_clock_extend(&c, 0xFFFFFFFFu) == 0xFFFFFFFFull);
  assert_true(skin_clock_extend(&c, 0x00000010u) == 0x100000010ull);
  assert_true(skin_clock_extend(&c, 0x00000020u) == 0x100000020ull);
}

static void many_wraps_count_up(void **state) {
  (void)state;
  skin_clock_t c;
  skin_clock_init(&c, 0u);
  uint64_t expected = 0;
  /* Steps of 2^30 + 7 us: four readings per wrap, never the same phase twice. */
  for (int i = 0; i < 40; i++) {
    expected += (1ull << 30) + 7u;
    assert_true(skin_clock_extend(&c, (uint32_t)expected) == expected);
  }
  assert_true(expected > (9ull << 32));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(no_wrap_keeps_the_reading),
      cmocka_unit_test(wrap_carries_into_the_high_word),
      cmocka_unit_test(many_wraps_count_up),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
