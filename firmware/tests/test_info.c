/* The board-information frame (docs/protocol.md, "Board information frame"). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "skin_fw/crc.h"
#include "skin_fw/fault.h"
#include "skin_fw/info.h"

static skin_board_info_t board(const char *name) {
  skin_board_info_t b = {.name = name, .scan_rate_hz = 1000u};
  const uint8_t uid[12] = {0x00, 0x39, 0x00, 0x1e, 0x34, 0x38, 0x51, 0x0b, 0x34, 0x31, 0x39, 0x39};
  memcpy(b.uid, uid, sizeof uid);
  return b;
}

static void text_and_layout(void **state) {
  (void)state;
  uint8_t out[SKIN_INFO_MAX_SIZE];
  skin_board_info_t b = board("nucleo-f446re");
  const char *text =
      "board=nucleo-f446re;uid=0039001e3438510b34313939;fw=0.1.0;grid=16x16;pitch_um=5000;"
      "rate_hz=1000";
  const uint32_t len = skin_info_build(out, &b, NULL, "0.1.0", 16, 16, 5000);
  const uint32_t tlen = (uint32_t)strlen(text);
  assert_int_equal(len, 6 + tlen);
  assert_int_equal(out[0], 0xA5);
  assert_int_equal(out[1], 0x69);
  assert_int_equal(out[2], 1);
  assert_int_equal(out[3], tlen);
  assert_memory_equal(out + 4, text, tlen);
  const uint16_t crc = skin_crc16(out, 4 + tlen);
  assert_int_equal(out[4 + tlen], crc & 0xFF);
  assert_int_equal(out[5 + tlen], crc >> 8);
}

static void extreme_grid_and_rate(void **state) {
  (void)state;
  uint8_t out[SKIN_INFO_MAX_SIZE];
  skin_board_info_t b = board("q");
  b.scan_rate_hz = 4294967295u;
  const uint32_t len = skin_info_build(out, &b, NULL, "10.20.30", 128, 1, 0);
  const char *tail = ";fw=10.20.30;grid=128x1;pitch_um=0;rate_hz=4294967295";
  assert_memory_equal(out + len - 2 - strlen(tail), tail, strlen(tail));
}

static void name_cannot_break_the_fields(void **state) {
  (void)state;
  uint8_t out[SKIN_INFO_MAX_SIZE];
  skin_board_info_t b = board("a;b=c\n\x7f");
  const uint32_t len = skin_info_build(out, &b, NULL, "0.1.0", 1, 1, 1);
  assert_true(len > 0);
  assert_memory_equal(out + 4, "board=a_b_c__;uid=", 18);
  for (uint32_t i = 4; i < len - 2; i++) {
    assert_true(out[i] >= 0x20 && out[i] <= 0x7E);
  }
}

static void too_long_a_text_is_refused(void **state) {
  (void)state;
  uint8_t out[SKIN_INFO_MAX_SIZE + 16];
  char name[201];
  memset(name, 'x', 200);
  name[200] = '\0';
  skin_board_info_t b = board(name);
  memset(out, 0x55, sizeof out);
  assert_int_equal(skin_info_build(out, &b, NULL, "0.1.0", 1, 1, 1), 0);
  /* Nothing written past the frame's largest size. */
  for (size_t i = SKIN_INFO_MAX_SIZE; i < sizeof out; i++) {
    assert_int_equal(out[i], 0x55);
  }
}

static const char *text_of(const uint8_t *out) {
  static char text[SKIN_INFO_MAX_TEXT + 1];
  memcpy(text, out + 4, out[3]);
  text[out[3]] = '\0';
  return text;
}

static void health_follows_the_six_keys(void **state) {
  (void)state;
  skin_faults_clear();
  skin_fault_count(SKIN_FAULT_ADC_OVERRUN);
  skin_fault_count(SKIN_FAULT_FRAME_FLAGGED);
  skin_fault_count(SKIN_FAULT_FRAME_FLAGGED);
  skin_fault_count(SKIN_FAULT_FRAME_DROPPED); /* version 1's: not sent by a version-2 board */
  uint8_t out[SKIN_INFO_MAX_SIZE];
  skin_board_info_t b = board("nucleo-f446re");
  const skin_board_status_t status = {.reset_cause = "iwdg", .fault = "busfault", .clock = "hsi"};
  const uint32_t len = skin_info_build(out, &b, &status, "0.1.0", 16, 16, 5000);
  assert_string_equal(text_of(out),
                      "board=nucleo-f446re;uid=0039001e3438510b34313939;fw=0.1.0;grid=16x16;"
                      "pitch_um=5000;rate_hz=1000;reset=iwdg;fault=busfault;clock=hsi;flagged=2;"
                      "adc_ovr=1;adc_to=0;link_to=0;hse_lost=0;mux=0");
  assert_int_equal(len, 6u + out[3]);
  const uint16_t crc = skin_crc16(out, 4u + out[3]);
  assert_int_equal(out[4 + out[3]] | out[5 + out[3]] << 8, crc);
}

static void a_status_left_unknown_sends_only_the_counters(void **state) {
  (void)state;
  skin_faults_clear();
  uint8_t out[SKIN_INFO_MAX_SIZE];
  skin_board_info_t b = board("q");
  const skin_board_status_t status = {0};
  skin_info_build(out, &b, &status, "0.1.0", 1, 1, 1);
  assert_non_null(strstr(text_of(out), ";rate_hz=1000;flagged=0;adc_ovr=0;"));
  assert_null(strstr(text_of(out), "reset="));
}

/* Every counter at n, with the longest status the Nucleo sends with version 2: a fault record
 * (usagefault, the longest name) with the watchdog reset that ended its handler (iwdg; the
 * handler's own reset is sw, shorter), on HSI, at the version-2 scan rate. */
static const char *nucleo_text_with_every_counter_at(uint32_t n, uint8_t *out) {
  skin_faults_clear();
  for (uint32_t i = 0; i < n; i++) {
    for (unsigned f = 0; f < SKIN_FAULTS; f++) {
      skin_fault_count((skin_fault_t)f);
    }
  }
  skin_board_info_t b = board("nucleo-f446re");
  b.scan_rate_hz = 100u;
  const skin_board_status_t status = {
      .reset_cause = "iwdg", .fault = "usagefault", .clock = "hsi"};
  skin_info_build(out, &b, &status, "0.1.0", 16, 16, 5000);
  return text_of(out);
}

static void the_nucleo_text_holds_every_counter_up_to_three_digits(void **state) {
  (void)state;
  uint8_t out[SKIN_INFO_MAX_SIZE];
  const char *text = nucleo_text_with_every_counter_at(999u, out);
  const char *tail = ";flagged=999;adc_ovr=999;adc_to=999;link_to=999;hse_lost=999;mux=999";
  assert_int_equal(strlen(text), SKIN_INFO_MAX_TEXT); /* exactly full */
  assert_string_equal(text + strlen(text) - strlen(tail), tail);
}

static void four_digit_counters_leave_the_last_one_out_whole(void **state) {
  /* 206 bytes with mux=9999: mux is left out whole (197), the counters before it all there. */
  (void)state;
  uint8_t out[SKIN_INFO_MAX_SIZE];
  const char *text = nucleo_text_with_every_counter_at(9999u, out);
  const char *tail = ";flagged=9999;adc_ovr=9999;adc_to=9999;link_to=9999;hse_lost=9999";
  assert_int_equal(strlen(text), 197);
  assert_string_equal(text + strlen(text) - strlen(tail), tail);
  assert_null(strstr(text, "mux="));
}

static void a_field_that_does_not_fit_is_left_out_whole(void **state) {
  /* A long board name leaves room for some fields only: the text stays key=value throughout,
   * the fields that fit are there in order, and no field is cut. */
  (void)state;
  skin_faults_clear();
  for (unsigned f = 0; f < SKIN_FAULTS; f++) {
    skin_fault_count((skin_fault_t)f);
  }
  char name[100];
  memset(name, 'n', 99);
  name[99] = '\0';
  uint8_t out[SKIN_INFO_MAX_SIZE];
  skin_board_info_t b = board(name);
  const skin_board_status_t status = {.reset_cause = "por", .clock = "hse"};
  const uint32_t len = skin_info_build(out, &b, &status, "0.1.0", 16, 16, 5000);
  assert_true(len > 0);
  /* 181 bytes before the status: ";reset=por" fits (191), ";clock=hse", ";flagged=1" and
   * ";adc_ovr=1" would not (201), ";adc_to=1" fits (200), and no other counter does. */
  const char *text = text_of(out);
  assert_int_equal(strlen(text), 200);
  assert_string_equal(text + 168, ";rate_hz=1000;reset=por;adc_to=1");
}

/* Send at each given scan time when due; return which scans went with an information frame. */
static uint32_t sends(skin_info_schedule_t *s, const uint64_t *times, uint32_t n) {
  uint32_t mask = 0u;
  for (uint32_t i = 0; i < n; i++) {
    if (skin_info_due(s, times[i])) {
      skin_info_sent(s, times[i]);
      mask |= 1u << i;
    }
  }
  return mask;
}

static void the_schedule_keeps_to_whole_periods_of_device_time(void **state) {
  (void)state;
  skin_info_schedule_t s;
  skin_info_schedule_init(&s, 1000000u);
  /* Scans 300 ms apart from 0.1 s: at the first scan, then at the first one at or after 1.1 s
   * and 2.1 s (1.3 and 2.2 s), not a period after each late send (which would be 2.3 s). */
  const uint64_t times[] = {100000u, 400000u, 700000u, 1000000u, 1300000u, 1600000u,
                            1900000u, 2200000u, 2500000u};
  assert_int_equal(sends(&s, times, 9), 0x1u | 0x10u | 0x80u);
}

static void after_a_stall_one_frame_then_a_period_later(void **state) {
  (void)state;
  skin_info_schedule_t s;
  skin_info_schedule_init(&s, 1000000u);
  /* A stall from 0.5 s to 5.8 s: one frame at 5.8 s (not five), the next at 6.8 s. */
  const uint64_t times[] = {0u, 500000u, 5800000u, 5900000u, 6700000u, 6800000u, 7700000u};
  assert_int_equal(sends(&s, times, 7), 0x1u | 0x4u | 0x20u);
}

static void the_schedule_runs_on_64_bit_device_time(void **state) {
  (void)state;
  skin_info_schedule_t s;
  skin_info_schedule_init(&s, 1000000u);
  /* Past 2^32 us, where the board's 32-bit clock wraps: a 32-bit due time would make every
   * scan after the wrap due (or none). */
  const uint64_t wrap = 1ull << 32;
  const uint64_t times[] = {wrap - 600000u, wrap - 100000u, wrap + 300000u, wrap + 400000u,
                            wrap + 500000u};
  assert_int_equal(sends(&s, times, 5), 0x1u | 0x8u);
}

static void due_now_goes_at_the_next_scan_and_the_period_restarts_from_it(void **state) {
  (void)state;
  skin_info_schedule_t s;
  skin_info_schedule_init(&s, 1000000u);
  const uint64_t before[] = {0u, 300000u};
  assert_int_equal(sends(&s, before, 2), 0x1u);
  /* A reader came at 0.35 s: one at 0.4 s (not at 1.0 s), the next at 1.4 s, not 1.0 s. */
  skin_info_due_now(&s);
  const uint64_t after[] = {400000u, 500000u, 1000000u, 1300000u, 1400000u, 1500000u};
  assert_int_equal(sends(&s, after, 6), 0x1u | 0x10u);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(text_and_layout),
      cmocka_unit_test(extreme_grid_and_rate),
      cmocka_unit_test(name_cannot_break_the_fields),
      cmocka_unit_test(too_long_a_text_is_refused),
      cmocka_unit_test(health_follows_the_six_keys),
      cmocka_unit_test(a_status_left_unknown_sends_only_the_counters),
      cmocka_unit_test(the_nucleo_text_holds_every_counter_up_to_three_digits),
      cmocka_unit_test(four_digit_counters_leave_the_last_one_out_whole),
      cmocka_unit_test(a_field_that_does_not_fit_is_left_out_whole),
      cmocka_unit_test(the_schedule_keeps_to_whole_periods_of_device_time),
      cmocka_unit_test(after_a_stall_one_frame_then_a_period_later),
      cmocka_unit_test(the_schedule_runs_on_64_bit_device_time),
      cmocka_unit_test(due_now_goes_at_the_next_scan_and_the_period_restarts_from_it),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
