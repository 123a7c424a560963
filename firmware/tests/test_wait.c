/* The bounded waits the boards build on (skin_fw/wait.h): each ends, in its bound. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "fake_board.h"
#include "skin_fw/wait.h"

static int setup(void **state) {
  (void)state;
  fake_reset();
  return 0;
}

static void a_flag_already_set_ends_the_wait_at_once(void **state) {
  (void)state;
  volatile uint32_t reg = 0x2u;
  assert_true(skin_wait_bits(&reg, 0x2u, 0x2u, 0u));
  assert_true(skin_wait_bits(&reg, 0x3u, 0x2u, 5u));
}

static void a_flag_never_set_ends_the_wait_false(void **state) {
  /* HSE, PLL and over-drive ready flags of a chip where they never come: the start-up goes on
   * (falls back, or records the fault and resets) instead of hanging. */
  (void)state;
  volatile uint32_t reg = 0u;
  assert_false(skin_wait_bits(&reg, 0x20000u, 0x20000u, 1000u));
}

static void polls_last_at_least_the_bound(void **state) {
  (void)state;
  /* 2 ms at the HSI's 16 MHz: 32 000 cycles, 8 000 polls of 4 cycles or more. */
  assert_int_equal(SKIN_WAIT_POLLS(2000u, 16000000u), 8000u);
  assert_int_equal(SKIN_WAIT_POLLS(1u, 16000000u), 4u);
  assert_int_equal(SKIN_WAIT_POLLS(50000u, 16000000u), 200000u);
}

static void done_before_the_bound(void **state) {
  (void)state;
  volatile uint32_t reg = 0x20u;
  assert_int_equal(skin_wait_flags(&reg, 0x20u, 0x08u, 39u), SKIN_WAIT_DONE);
}

static void a_fail_bit_wins_over_done(void **state) {
  /* The ADC's DMA with a transfer error: the row is not taken even when complete is set too. */
  (void)state;
  volatile uint32_t reg = 0x28u;
  assert_int_equal(skin_wait_flags(&reg, 0x20u, 0x08u, 39u), SKIN_WAIT_FAILED);
}

static void a_transfer_that_never_completes_times_out_just_past_its_bound(void **state) {
  /* The ADC's DMA that never completes: the wait ends once the device clock passed the bound,
   * not before and not much after (each reading of the clock takes 1 us here). */
  (void)state;
  fake.time_us32 = 0xFFFFFFF0u; /* across the 32-bit clock's wrap */
  fake.read_us = 1u;
  volatile uint32_t reg = 0u;
  assert_int_equal(skin_wait_flags(&reg, 0x20u, 0x08u, 39u), SKIN_WAIT_TIMEOUT);
  const uint32_t waited = fake.time_us32 - 0xFFFFFFF0u;
  assert_in_range(waited, 40u, 42u);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test_setup(a_flag_already_set_ends_the_wait_at_once, setup),
      cmocka_unit_test_setup(a_flag_never_set_ends_the_wait_false, setup),
      cmocka_unit_test_setup(polls_last_at_least_the_bound, setup),
      cmocka_unit_test_setup(done_before_the_bound, setup),
      cmocka_unit_test_setup(a_fail_bit_wins_over_done, setup),
      cmocka_unit_test_setup(a_transfer_that_never_completes_times_out_just_past_its_bound, setup),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
