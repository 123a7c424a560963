/* skin_fw_run's start and loop with the fake board and the test config (3 x 5, config/). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "fake_board.h"
#include "skin_fw/frame.h"
#include "skin_fw/fw.h"
#include "skin_fw_config.h"

static int is_info(uint32_t i) { return fake.sent[i][0] == 0xA5 && fake.sent[i][1] == 0x69; }
static int is_frame(uint32_t i) {
  return fake.sent[i][0] == 0xA5 && fake.sent[i][1] == 0x5A &&
         fake.sent_len[i] == SKIN_FRAME_V2_SIZE(SKIN_FW_ROWS, SKIN_FW_COLS);
}

static int setup(void **state) {
  (void)state;
  fake_reset();
  return 0;
}

static void boot_sends_the_information_before_the_first_frame(void **state) {
  (void)state;
  skin_fw_start();
  fake_drain();
  assert_int_equal(fake.n_sent, 1);
  assert_true(is_info(0));
  const char *text = "board=fake;uid=01112131415161718191a1b1;fw=1.2.3;grid=3x5;pitch_um=4500;"
                     "rate_hz=1000";
  assert_int_equal(fake.sent[0][3], strlen(text));
  assert_memory_equal(fake.sent[0] + 4, text, strlen(text));
  for (int i = 0; i < 3; i++) {
    skin_fw_step();
  }
  fake_drain();
  assert_int_equal(fake.n_sent, 4);
  for (uint32_t i = 1; i < 4; i++) {
    assert_true(is_frame(i));
    assert_int_equal(fake.sent[i][4], i - 1); /* seq */
  }
}

static void each_step_waits_for_the_tick_then_scans(void **state) {
  (void)state;
  skin_fw_start();
  const uint32_t before = fake.n_events;
  skin_fw_step();
  assert_int_equal(fake.events[before].kind, EV_TICK);
  assert_int_equal(fake.events[before + 1].kind, EV_DRIVE);
  assert_int_equal(fake.events[before + 2].value, SKIN_FW_SETTLE_US);
}

static void information_repeats_once_a_second_between_frames(void **state) {
  (void)state;
  fake.time_step_us = 100000u; /* ten scans a second */
  fake.busy_polls = 3;
  skin_fw_start();
  for (int i = 0; i < 35; i++) {
    skin_fw_step();
  }
  fake_drain();
  assert_int_equal(fake.sends_while_busy, 0);
  uint32_t infos = 0, frames = 0;
  for (uint32_t i = 0; i < fake.n_sent; i++) {
    if (is_info(i)) {
      if (infos) {
        /* Right before the scan at 1.0 s, 2.0 s, ... of device time (seq 9, 19, ...). */
        assert_true(i + 1 < fake.n_sent && is_frame(i + 1));
        assert_int_equal(fake.sent[i + 1][4] % 10, 9);
      }
      infos++;
    } else {
      assert_true(is_frame(i));
      frames++;
    }
  }
  assert_int_equal(frames, 35);
  assert_int_equal(infos, 4); /* boot, then at 1 s, 2 s and 3 s */
}

static void information_keeps_to_whole_seconds_when_scans_come_off_the_second(void **state) {
  (void)state;
  /* Scans 300 ms apart: an information frame goes out at the first scan at or after each whole
     second, up to 200 ms late, and the next one is still due at the next whole second, not a
     second after the late one (which would lose one frame in six). */
  fake.time_step_us = 300000u;
  skin_fw_start();
  for (int i = 0; i < 40; i++) { /* the last scan at 12.0 s */
    skin_fw_step();
  }
  fake_drain();
  uint32_t infos = 0;
  for (uint32_t i = 0; i < fake.n_sent; i++) {
    infos += is_info(i);
  }
  assert_int_equal(infos, 13); /* boot, then at 1.2, 2.1, 3.0, 4.2, ... 12.0 s */
}

static void after_a_stall_one_information_frame_not_a_burst(void **state) {
  (void)state;
  fake.time_step_us = 100000u;
  skin_fw_start();
  for (int i = 0; i < 5; i++) {
    skin_fw_step();
  }
  fake.time_step_us = 5000000u; /* the board stalls for 5 s */
  skin_fw_step();
  fake.time_step_us = 100000u;
  for (int i = 0; i < 9; i++) {
    skin_fw_step();
  }
  fake_drain();
  uint32_t infos = 0;
  for (uint32_t i = 0; i < fake.n_sent; i++) {
    infos += is_info(i);
  }
  assert_int_equal(infos, 2); /* boot, then one after the stall; the next is due 1 s later */
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test_setup(boot_sends_the_information_before_the_first_frame, setup),
      cmocka_unit_test_setup(each_step_waits_for_the_tick_then_scans, setup),
      cmocka_unit_test_setup(information_repeats_once_a_second_between_frames, setup),
      cmocka_unit_test_setup(information_keeps_to_whole_seconds_when_scans_come_off_the_second,
                             setup),
      cmocka_unit_test_setup(after_a_stall_one_information_frame_not_a_burst, setup),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
