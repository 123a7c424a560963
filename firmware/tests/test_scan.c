/*
 * The scan sequencer against the fake board (a 4 x 3 grid, settle time 13 us), each test in
 * both protocol versions.
 */
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
#include "skin_fw/mux_check.h"
#include "skin_fw/scan.h"

#define ROWS 4
#define COLS 3
#define SETTLE 13u

static uint32_t buf0[SKIN_FRAME_BUFFER_WORDS(ROWS, COLS)];
static uint32_t buf1[SKIN_FRAME_BUFFER_WORDS(ROWS, COLS)];
static skin_scan_t scan;
static uint8_t version;

static int setup(uint8_t v) {
  fake_reset();
  memset(buf0, 0xEE, sizeof buf0);
  memset(buf1, 0xEE, sizeof buf1);
  skin_scan_init(&scan, buf0, buf1, ROWS, COLS, SETTLE);
  skin_link_init(0u);
  version = v;
  scan.version = v;
  return 0;
}

static int setup_v1(void **state) {
  (void)state;
  return setup(1);
}

static int setup_v2(void **state) {
  (void)state;
  return setup(2);
}

static uint32_t get_le(const uint8_t *p, int bytes) {
  uint32_t v = 0;
  for (int i = bytes - 1; i >= 0; i--) {
    v = (v << 8) | p[i];
  }
  return v;
}

/* Count i (top then bottom, row-major) of the frame f of this test's version. */
static uint32_t count_at(const uint8_t *f, uint32_t i) {
  if (version == 1) {
    return get_le(f + 20 + 2 * i, 2);
  }
  const uint32_t pair = get_le(f + SKIN_FRAME_V2_COUNTS_AT(ROWS) + 3 * (i / 2), 3);
  return (i % 2) ? pair >> 12 : pair & 0xFFFu;
}

/*
 * The frame of scan number `index` is intact and carries that scan's counts and this seq;
 * version 2: its row map has a 0 for row `failed - 1` of the bottom layer (failed 0: none),
 * whose counts are 0.
 */
static void assert_frame_v(const uint8_t *f, uint32_t len, uint32_t index, uint32_t seq,
                           uint32_t failed, uint16_t faults) {
  assert_int_equal(len, skin_frame_size(version, ROWS, COLS));
  assert_int_equal(f[0], 0xA5);
  assert_int_equal(f[1], 0x5A);
  assert_int_equal(f[2], version);
  if (version == 2) {
    const uint8_t want_map = (uint8_t)(failed ? 0x0Fu & ~(1u << (failed - 1)) : 0x0Fu);
    assert_int_equal(f[22], 0x0F);
    assert_int_equal(f[23], want_map);
    assert_int_equal(get_le(f + 20, 2), faults | (failed ? SKIN_FAULT_ROW_FAILED : 0u));
    assert_int_equal(f[3], (failed ? SKIN_FLAG_ROWS_INVALID : 0u) |
                               ((faults || failed) ? SKIN_FLAG_FAULT : 0u));
    for (uint32_t i = SKIN_FRAME_V2_BODY(ROWS, COLS); i < len - 4; i++) {
      assert_int_equal(f[i], 0); /* padding */
    }
  } else {
    assert_int_equal(f[3], 0);
  }
  assert_int_equal(get_le(f + 4, 4), seq);
  assert_int_equal(f[16], ROWS);
  assert_int_equal(f[17], COLS);
  assert_int_equal(get_le(f + 18, 2), skin_crc16(f, 18));
  for (uint8_t layer = 0; layer < 2; layer++) {
    for (uint8_t r = 0; r < ROWS; r++) {
      for (uint8_t c = 0; c < COLS; c++) {
        const bool marked = layer == 1 && failed && r == failed - 1;
        assert_int_equal(count_at(f, (layer * ROWS + r) * COLS + c),
                         marked ? 0u : fake_count(index, layer, r, c));
      }
    }
  }
  assert_int_equal(get_le(f + len - 4, 4), skin_crc32(f, len - 4));
}

static void assert_frame(const uint8_t *f, uint32_t len, uint32_t index, uint32_t seq) {
  assert_frame_v(f, len, index, seq, 0, 0);
}

static void rows_are_driven_in_order_settled_sampled_then_released(void **state) {
  (void)state;
  (void)skin_scan_fill(&scan);
  uint32_t e = 0;
  for (uint8_t layer = 0; layer < 2; layer++) {
    for (uint8_t r = 0; r < ROWS; r++) {
      assert_int_equal(fake.events[e].kind, EV_DRIVE);
      assert_int_equal(fake.events[e].layer, layer);
      assert_int_equal(fake.events[e].row, r);
      assert_int_equal(fake.events[e + 1].kind, EV_DELAY);
      assert_int_equal(fake.events[e + 1].value, SETTLE);
      assert_int_equal(fake.events[e + 2].kind, EV_SAMPLE);
      assert_int_equal(fake.events[e + 2].value, COLS);
      e += 3;
    }
  }
  assert_int_equal(fake.events[e].kind, EV_RELEASE);
  assert_int_equal(fake.n_events, e + 1);
}

static void samples_land_in_their_payload_slots(void **state) {
  (void)state;
  (void)skin_scan_fill(&scan);
  const uint16_t *payload = skin_frame_counts((uint8_t *)buf0, version, ROWS);
  for (uint32_t k = 0; k < 2 * ROWS; k++) {
    assert_ptr_equal(fake.events[3 * k + 2].ptr, payload + k * COLS);
  }
}

static void slack_does_not_spoil_the_frame(void **state) {
  (void)state;
  /* The fake writes 0xFFFF into the slack after every row, the last one's over the check. */
  const uint32_t len = skin_scan_fill(&scan);
  assert_frame((const uint8_t *)buf0, len, 0, 0);
}

static void time_is_the_scan_start_extended_past_32_bits(void **state) {
  (void)state;
  fake.time_us32 = 0xFFFFFF00u;
  skin_scan_init(&scan, buf0, buf1, ROWS, COLS, SETTLE);
  uint32_t len = skin_scan_fill(&scan);
  assert_true(get_le((uint8_t *)buf0 + 8, 4) == 0xFFFFFF00u);
  assert_int_equal(get_le((uint8_t *)buf0 + 12, 4), 0);
  skin_scan_send(&scan, len);
  fake.time_us32 = 0x00000100u;
  len = skin_scan_fill(&scan);
  assert_int_equal(get_le((uint8_t *)buf1 + 8, 4), 0x100u);
  assert_int_equal(get_le((uint8_t *)buf1 + 12, 4), 1);
  assert_true(scan.last_time_us == 0x100000100ull);
}

static void seq_counts_up_and_wraps(void **state) {
  (void)state;
  scan.seq = 0xFFFFFFFEu;
  const uint32_t want[] = {0xFFFFFFFEu, 0xFFFFFFFFu, 0u, 1u};
  for (uint32_t i = 0; i < 4; i++) {
    const uint32_t len = skin_scan_fill(&scan);
    skin_scan_send(&scan, len);
  }
  fake_drain();
  assert_int_equal(fake.n_sent, 4);
  for (uint32_t i = 0; i < 4; i++) {
    assert_frame(fake.sent[i], fake.sent_len[i], i, want[i]);
  }
}

static void never_fills_the_buffer_the_link_is_sending(void **state) {
  (void)state;
  /* A slow DMA link: each send still runs while the next scan is made. */
  fake.busy_polls = 50;
  for (uint32_t i = 0; i < 7; i++) {
    const uint32_t len = skin_scan_fill(&scan);
    skin_scan_send(&scan, len);
  }
  fake_drain();
  assert_int_equal(fake.samples_into_in_flight, 0);
  assert_int_equal(fake.sends_while_busy, 0);
  assert_int_equal(fake.n_sent, 7);
  uint32_t sends = 0;
  for (uint32_t e = 0; e < fake.n_events; e++) {
    if (fake.events[e].kind == EV_SEND) {
      /* The buffers take turns. */
      assert_ptr_equal(fake.events[e].ptr, (sends % 2) ? (void *)buf1 : (void *)buf0);
      sends++;
    }
  }
  for (uint32_t i = 0; i < 7; i++) {
    assert_frame(fake.sent[i], fake.sent_len[i], i, i);
  }
}

/* After scan 0 sent and scan 1 dropped: scan 2 is sent, numbered 1 (the drop took no number). */
static void the_third_scan_follows_the_first_as_number_1(void) {
  skin_scan_send(&scan, skin_scan_fill(&scan));
  fake_drain();
  assert_int_equal(fake.n_sent, 2);
  assert_frame(fake.sent[0], fake.sent_len[0], 0, 0);
  assert_frame(fake.sent[1], fake.sent_len[1], 2, 1);
}

static void a_failed_row_drops_its_version_1_scan_and_is_counted(void **state) {
  (void)state;
  /* Version 1 cannot mark a row. Scan 1 (the second) fails on bottom row 2: nothing of it is
   * sent, the scan stops there with the rows released, and the next frame carries the next
   * scan under the next number. */
  fake.fail_scan = 2u;
  fake.fail_layer = 1u;
  fake.fail_row = 2u;
  uint32_t len = skin_scan_fill(&scan);
  skin_scan_send(&scan, len);
  const uint32_t before = fake.n_events;
  assert_int_equal(skin_scan_fill(&scan), 0u);
  /* Drives of the 4 top rows and bottom rows 0..2, each driven, settled, sampled; release. */
  assert_int_equal(fake.n_events - before, 3u * (ROWS + 3u) + 1u);
  assert_int_equal(fake.events[fake.n_events - 1].kind, EV_RELEASE);
  the_third_scan_follows_the_first_as_number_1();
  assert_int_equal(skin_fault_get(SKIN_FAULT_FRAME_DROPPED), 1);
  assert_int_equal(skin_fault_get(SKIN_FAULT_ADC_OVERRUN), 1);
  assert_int_equal(skin_fault_get(SKIN_FAULT_LINK_TIMEOUT), 0);
}

/* The largest count of a layer of a sent frame. */
static uint16_t layer_max(const uint8_t *f, uint8_t layer) {
  uint16_t m = 0;
  for (uint32_t k = 0; k < ROWS * COLS; k++) {
    const uint16_t v = (uint16_t)count_at(f, layer * ROWS * COLS + k);
    m = v > m ? v : m;
  }
  return m;
}

static void rows_alike_while_pressed_drop_the_scan_and_are_counted(void **state) {
  (void)state;
  /* Scan 1: the mux selects row 1 whatever row is driven; the bottom layer (counts from 2048)
   * is pressed. Not sent in either version (a row map cannot say "this row is another's"):
   * counted as mux only (drop is version 1's failed row), no sequence number taken. */
  uint32_t len = skin_scan_fill(&scan);
  skin_scan_send(&scan, len);
  fake.mux_stuck = true;
  fake.mux_stuck_row = 1u;
  assert_int_equal(skin_scan_fill(&scan), 0u);
  assert_int_equal(fake.events[fake.n_events - 1].kind, EV_RELEASE);
  fake.mux_stuck = false;
  the_third_scan_follows_the_first_as_number_1();
  assert_int_equal(skin_fault_get(SKIN_FAULT_MUX_STUCK), 1);
  assert_int_equal(skin_fault_get(SKIN_FAULT_FRAME_DROPPED), 0);
  assert_int_equal(skin_fault_get(SKIN_FAULT_FRAME_FLAGGED), 0);
}

static void rows_alike_at_idle_are_sent(void **state) {
  (void)state;
  /* Every count below 64: a stuck mux cannot be told from an untouched skin; sent. */
  fake.idle = true;
  fake.mux_stuck = true;
  fake.mux_stuck_row = 2u;
  const uint32_t len = skin_scan_fill(&scan);
  assert_int_equal(len, skin_frame_size(version, ROWS, COLS));
  skin_scan_send(&scan, len);
  fake_drain();
  assert_int_equal(fake.n_sent, 1);
  const uint8_t *f = fake.sent[0];
  for (uint32_t c = 0; c < COLS; c++) {
    assert_int_equal(count_at(f, COLS + c), count_at(f, c)); /* row 1 is row 0 */
  }
  assert_int_equal(skin_fault_get(SKIN_FAULT_MUX_STUCK), 0);
  assert_int_equal(skin_fault_get(SKIN_FAULT_FRAME_DROPPED), 0);
}

static void a_healthy_press_is_sent(void **state) {
  (void)state;
  const uint32_t len = skin_scan_fill(&scan);
  skin_scan_send(&scan, len);
  fake_drain();
  assert_int_equal(fake.n_sent, 1);
  assert_frame(fake.sent[0], fake.sent_len[0], 0, 0);
  assert_true(layer_max(fake.sent[0], 1) > SKIN_MUX_PRESSED); /* pressed, rows differ */
  assert_int_equal(skin_fault_get(SKIN_FAULT_MUX_STUCK), 0);
}

static void rows_within_the_noise_are_alike(void **state) {
  (void)state;
  /* 2 x 2 x 2: the top layer idle and unlike, the bottom pressed (3000) with rows 16 apart. */
  uint16_t counts[8] = {10, 40, 90, 5, 3000, 2000, 3016, 1984};
  assert_true(skin_mux_stuck(counts, 2, 2));
  counts[6] = 3017; /* one count past the noise: two lines */
  assert_false(skin_mux_stuck(counts, 2, 2));
  /* Rows alike at SKIN_MUX_PRESSED itself: not pressed. */
  const uint16_t at_threshold[4] = {SKIN_MUX_PRESSED, 7, SKIN_MUX_PRESSED, 7};
  assert_false(skin_mux_stuck(at_threshold, 1, 2)); /* one row: cannot be told */
  const uint16_t two_layers[8] = {SKIN_MUX_PRESSED, 7, SKIN_MUX_PRESSED, 7, 1, 2, 3, 4};
  assert_false(skin_mux_stuck(two_layers, 2, 2));
}

static void the_link_bound_is_the_bytes_time_twice_plus_the_slack(void **state) {
  (void)state;
  /* A 16 x 16 frame (1048 bytes) at 921 600 baud, 10 bits a byte: 10 851 ns a byte, 11.37 ms
   * on the line; bound 2 x 11 372 + 1000 us. */
  skin_link_init(10851u);
  assert_int_equal(skin_link_bound_us(1048u), 22744u + 1000u);
  /* A link that blocks in its send has nothing to wait for but the slack. */
  skin_link_init(0u);
  assert_int_equal(skin_link_bound_us(1048u), SKIN_LINK_SLACK_US);
}

static void a_transfer_that_never_completes_is_aborted_past_its_bound(void **state) {
  (void)state;
  /* USART TX DMA that never completes and moves no byte: the next send waits for the bound of
   * the one in progress, counts a link timeout, aborts it (bytes left: the link is reset) and
   * goes on; once the link works again frames arrive intact. */
  skin_link_init(1000u); /* 1 us a byte */
  fake.poll_us = 1u;
  fake.link_stalls = 1u;
  uint32_t len = skin_scan_fill(&scan);
  assert_int_equal(skin_scan_send(&scan, len), SKIN_LINK_DONE);
  const uint32_t sent_at = fake.time_us32;
  len = skin_scan_fill(&scan);
  assert_int_equal(skin_scan_send(&scan, len), SKIN_LINK_STALLED);
  /* Polled 1 us at a time until the bound was passed: bound + 1 us, not sooner. */
  assert_int_equal(fake.time_us32 - sent_at, skin_link_bound_us(len) + 1u);
  assert_int_equal(fake.aborts, 1);
  assert_int_equal(fake.cut_sends, 1);
  assert_int_equal(skin_fault_get(SKIN_FAULT_LINK_TIMEOUT), 1);
  len = skin_scan_fill(&scan);
  assert_int_equal(skin_scan_send(&scan, len), SKIN_LINK_DONE);
  fake_drain();
  /* The stalled transfer never reached the host whole; the two after it did, in order. */
  assert_int_equal(fake.n_sent, 2);
  assert_frame(fake.sent[0], fake.sent_len[0], 1, 1);
  assert_frame(fake.sent[1], fake.sent_len[1], 2, 2);
}

static void a_completion_lost_after_the_last_byte_is_late_not_stalled(void **state) {
  (void)state;
  /* Every byte went, only the DMA's completion never came: counted as a link timeout, the
   * frame is whole, the link is not reset. */
  skin_link_init(1000u);
  fake.poll_us = 1u;
  fake.link_loses_completion = 1u;
  uint32_t len = skin_scan_fill(&scan);
  skin_scan_send(&scan, len);
  len = skin_scan_fill(&scan);
  assert_int_equal(skin_scan_send(&scan, len), SKIN_LINK_LATE);
  fake_drain();
  assert_int_equal(fake.cut_sends, 0);
  assert_int_equal(fake.n_sent, 2);
  assert_frame(fake.sent[0], fake.sent_len[0], 0, 0);
  assert_int_equal(skin_fault_get(SKIN_FAULT_LINK_TIMEOUT), 1);
}

static void a_failed_row_is_marked_in_its_version_2_frame_only(void **state) {
  (void)state;
  /* Scan 0 fails on bottom row 2: its frame is sent with the row marked, its counts zeroed and
   * the row-failed bit set, counted as flagged (not dropped); scan 1 is whole again. */
  fake.fail_scan = 1u;
  fake.fail_layer = 1u;
  fake.fail_row = 2u;
  uint32_t len = skin_scan_fill(&scan);
  skin_scan_send(&scan, len);
  len = skin_scan_fill(&scan);
  skin_scan_send(&scan, len);
  fake_drain();
  assert_int_equal(fake.n_sent, 2);
  assert_frame_v(fake.sent[0], fake.sent_len[0], 0, 0, 3, 0);
  assert_frame(fake.sent[1], fake.sent_len[1], 1, 1);
  assert_int_equal(skin_fault_get(SKIN_FAULT_FRAME_FLAGGED), 1);
  assert_int_equal(skin_fault_get(SKIN_FAULT_FRAME_DROPPED), 0);
  assert_int_equal(skin_fault_get(SKIN_FAULT_ADC_OVERRUN), 1);
}

static void fault_bits_go_into_the_next_frame_once(void **state) {
  (void)state;
  skin_scan_fault(SKIN_FAULT_SCAN_OVERRUN);
  skin_scan_fault(SKIN_FAULT_CLOCK);
  uint32_t len = skin_scan_fill(&scan);
  skin_scan_send(&scan, len);
  len = skin_scan_fill(&scan);
  skin_scan_send(&scan, len);
  fake_drain();
  assert_frame_v(fake.sent[0], fake.sent_len[0], 0, 0, 0,
                 SKIN_FAULT_SCAN_OVERRUN | SKIN_FAULT_CLOCK);
  assert_frame(fake.sent[1], fake.sent_len[1], 1, 1);
}

static void version_1_carries_no_fault_bits(void **state) {
  (void)state;
  skin_scan_fault(SKIN_FAULT_CLOCK);
  const uint32_t len = skin_scan_fill(&scan);
  assert_frame((const uint8_t *)buf0, len, 0, 0);
}

#define BOTH(test)                                   \
  cmocka_unit_test_setup(test, setup_v1), cmocka_unit_test_setup(test, setup_v2)

int main(void) {
  const struct CMUnitTest tests[] = {
      BOTH(rows_are_driven_in_order_settled_sampled_then_released),
      BOTH(samples_land_in_their_payload_slots),
      BOTH(slack_does_not_spoil_the_frame),
      BOTH(time_is_the_scan_start_extended_past_32_bits),
      BOTH(seq_counts_up_and_wraps),
      BOTH(never_fills_the_buffer_the_link_is_sending),
      cmocka_unit_test_setup(a_failed_row_drops_its_version_1_scan_and_is_counted, setup_v1),
      cmocka_unit_test_setup(a_failed_row_is_marked_in_its_version_2_frame_only, setup_v2),
      BOTH(rows_alike_while_pressed_drop_the_scan_and_are_counted),
      BOTH(rows_alike_at_idle_are_sent),
      BOTH(a_healthy_press_is_sent),
      cmocka_unit_test_setup(rows_within_the_noise_are_alike, setup_v2),
      cmocka_unit_test_setup(the_link_bound_is_the_bytes_time_twice_plus_the_slack, setup_v2),
      BOTH(a_transfer_that_never_completes_is_aborted_past_its_bound),
      BOTH(a_completion_lost_after_the_last_byte_is_late_not_stalled),
      cmocka_unit_test_setup(fault_bits_go_into_the_next_frame_once, setup_v2),
      cmocka_unit_test_setup(version_1_carries_no_fault_bits, setup_v1),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
