/* skin_fw_run's start and loop with the fake board and the test config (3 x 5, config/). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "fake_board.h"
#include "skin_fw/crc.h"
#include "skin_fw/fault.h"
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
                     "rate_hz=1000;flagged=0;adc_ovr=0;adc_to=0;link_to=0;hse_lost=0;mux=0";
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

/* A new reader between scans (the USB port opened): the information frame goes ahead of the
 * next frame, not at the next whole second, and the one after a second later. */
static void a_new_reader_gets_the_information_ahead_of_the_next_frame(void **state) {
  (void)state;
  fake.time_step_us = 100000u;
  skin_fw_start();
  for (int i = 0; i < 3; i++) { /* scans at 0.1 .. 0.3 s */
    skin_fw_step();
  }
  skin_fw_info_now();
  for (int i = 0; i < 12; i++) { /* 0.4 .. 1.5 s */
    skin_fw_step();
  }
  fake_drain();
  /* Boot's, then ahead of seq 3 (0.4 s) and seq 13 (1.4 s): none at 1.0 s. */
  uint32_t infos = 0;
  for (uint32_t i = 0; i < fake.n_sent; i++) {
    if (is_info(i)) {
      if (infos) {
        assert_true(i + 1 < fake.n_sent && is_frame(i + 1));
        assert_int_equal(fake.sent[i + 1][4], infos == 1 ? 3 : 13);
      }
      infos++;
    }
  }
  assert_int_equal(infos, 3);
}

static uint32_t le32(const uint8_t *p) {
  return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* Bottom row `row` of version-2 frame i is marked not sampled, and no other row is. */
static bool only_marked(uint32_t i, int row) {
  const uint8_t *f = fake.sent[i];
  const uint8_t all = (uint8_t)((1u << SKIN_FW_ROWS) - 1u); /* the test grid has < 8 rows */
  const uint8_t bottom = (uint8_t)(row < 0 ? all : all & ~(1u << row));
  return f[22] == all && f[23] == bottom;
}

/* A frame the host accepts with every row valid: both checks right, the rows all sampled. */
static void assert_valid_frame(uint32_t i) {
  const uint8_t *f = fake.sent[i];
  const uint32_t len = fake.sent_len[i];
  assert_true(is_frame(i));
  assert_int_equal(f[18] | f[19] << 8, skin_crc16(f, 18));
  assert_int_equal(le32(f + len - 4), skin_crc32(f, len - 4));
  assert_true(only_marked(i, -1));
  assert_int_equal(f[3] & SKIN_FLAG_ROWS_INVALID, 0);
}

static uint32_t feeds_in(uint32_t steps) {
  const uint32_t before = fake.feeds;
  for (uint32_t i = 0; i < steps; i++) {
    skin_fw_step();
  }
  return fake.feeds - before;
}

static void the_watchdog_is_fed_once_per_healthy_scan(void **state) {
  (void)state;
  fake.busy_polls = 3;
  skin_fw_start();
  assert_int_equal(fake.feeds, 1); /* after the start-up */
  assert_int_equal(feeds_in(25), 25);
}

static void a_failed_row_still_feeds_the_watchdog(void **state) {
  /* A row that failed was recovered by the board: the loop is healthy, the scan is sent with
   * the row marked (version 2). */
  (void)state;
  fake.fail_scan = 3u;
  fake.fail_row = 1u;
  fake.fail_layer = 1u;
  skin_fw_start();
  assert_int_equal(feeds_in(5), 5);
  fake_drain();
  assert_int_equal(fake.n_sent, 1 + 5);
  for (uint32_t i = 1; i < fake.n_sent; i++) {
    assert_int_equal(le32(fake.sent[i] + 4), i - 1); /* every scan has its number */
    if (i != 3) {
      assert_valid_frame(i);
    }
  }
  assert_true(only_marked(3, 1));
  assert_int_equal(fake.sent[3][3], SKIN_FLAG_ROWS_INVALID | SKIN_FLAG_FAULT);
}

static void a_stalled_link_starves_the_watchdog_until_it_recovers(void **state) {
  /* Scan after scan the link stalls: no feed, so the IWDG resets the board if it persists;
   * once a transfer completes again, feeding resumes. */
  (void)state;
  fake.info.link_byte_ns = 1000u;
  fake.poll_us = 1u;
  skin_fw_start();
  fake.link_stalls = 4u; /* the next four transfers */
  /* Step 1's frame stalls, found by step 2 ... step 4's by step 5, whose own frame is fine. */
  assert_int_equal(feeds_in(1), 1);
  assert_int_equal(feeds_in(4), 0);
  assert_int_equal(feeds_in(3), 3);
  assert_int_equal(skin_fault_get(SKIN_FAULT_LINK_TIMEOUT), 4);
  fake_drain();
  for (uint32_t i = 1; i < fake.n_sent; i++) {
    assert_valid_frame(i);
  }
}

static void a_row_failing_on_every_scan_is_marked_in_every_frame_and_counted(void **state) {
  /* A row whose ADC overruns scan after scan: every frame marks it (never sent as counts), and
   * the information frame, once a second, names the fault and counts the flagged frames. */
  (void)state;
  fake.time_step_us = 100000u;
  fake.fail_scan = 1u;
  fake.fail_layer = 1u;
  fake.fail_persists = true;
  skin_fw_start();
  for (int i = 0; i < 12; i++) {
    skin_fw_step();
  }
  fake_drain();
  assert_int_equal(fake.n_sent, 2 + 12); /* the information frames at boot and at 1 s */
  uint32_t infos = 0;
  for (uint32_t i = 0; i < fake.n_sent; i++) {
    if (is_info(i)) {
      infos++;
      continue;
    }
    assert_true(only_marked(i, 0));
    assert_int_equal(fake.sent[i][20] | fake.sent[i][21] << 8, SKIN_FAULT_ROW_FAILED);
  }
  assert_int_equal(infos, 2);
  assert_true(is_info(0) && is_info(10));
  const char *want = ";flagged=10;adc_ovr=10;adc_to=0;link_to=0;hse_lost=0;mux=0";
  assert_memory_equal(fake.sent[10] + 4 + fake.sent[10][3] - strlen(want), want, strlen(want));
}

static void the_fault_bits_restate_the_boards_clock_and_reset(void **state) {
  /* clock=hsi and reset=iwdg in the information frame are bits 3 and 4 of every frame. */
  (void)state;
  fake.status = (skin_board_status_t){.reset_cause = "iwdg", .clock = "hsi"};
  skin_fw_start();
  skin_fw_step();
  fake.status.clock = "hse";
  skin_fw_step();
  fake_drain();
  assert_int_equal(fake.n_sent, 3);
  assert_int_equal(fake.sent[1][20], SKIN_FAULT_CLOCK | SKIN_FAULT_WATCHDOG_RESET);
  assert_int_equal(fake.sent[2][20], SKIN_FAULT_WATCHDOG_RESET);
  assert_int_equal(fake.sent[2][3], SKIN_FLAG_FAULT);
}

static void the_information_frame_carries_the_board_status(void **state) {
  (void)state;
  fake.status = (skin_board_status_t){.reset_cause = "iwdg", .clock = "hsi"};
  skin_fw_start();
  fake_drain();
  char text[256] = {0};
  memcpy(text, fake.sent[0] + 4, fake.sent[0][3]);
  assert_non_null(strstr(text, ";rate_hz=1000;reset=iwdg;clock=hsi;flagged=0;"));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test_setup(boot_sends_the_information_before_the_first_frame, setup),
      cmocka_unit_test_setup(each_step_waits_for_the_tick_then_scans, setup),
      cmocka_unit_test_setup(information_repeats_once_a_second_between_frames, setup),
      cmocka_unit_test_setup(information_keeps_to_whole_seconds_when_scans_come_off_the_second,
                             setup),
      cmocka_unit_test_setup(after_a_stall_one_information_frame_not_a_burst, setup),
      cmocka_unit_test_setup(the_watchdog_is_fed_once_per_healthy_scan, setup),
      cmocka_unit_test_setup(a_failed_row_still_feeds_the_watchdog, setup),
      cmocka_unit_test_setup(a_stalled_link_starves_the_watchdog_until_it_recovers, setup),
      cmocka_unit_test_setup(a_row_failing_on_every_scan_is_marked_in_every_frame_and_counted,
                             setup),
      cmocka_unit_test_setup(the_fault_bits_restate_the_boards_clock_and_reset, setup),
      cmocka_unit_test_setup(a_new_reader_gets_the_information_ahead_of_the_next_frame, setup),
      cmocka_unit_test_setup(the_information_frame_carries_the_board_status, setup),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
