/*
 * The link over USB (boards/nucleo_f446re/usb/usb_link.c) against a fake of the TinyUSB calls
 * it makes: a CDC transmit FIFO with a settable room, a host that has the port open or not, a
 * count of tud_task() calls (the stack getting the CPU), a line state the host sets that the
 * stack delivers in its next tud_task(), and the core's skin_fw_info_now() counted.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "skin_fw/board.h"
#include "skin_fw/fw.h"
#include "tusb.h"
#include "usb_link.h"

static struct {
  uint8_t fifo[4096]; /* what the host will receive, in order */
  uint32_t fifo_len;
  uint32_t room;      /* bytes the FIFO takes before it is full */
  bool connected;
  uint32_t tasks, flushes, clears;
  int line_dtr; /* a SET_CONTROL_LINE_STATE the stack has not handled yet: 0 or 1, -1 none */
  uint32_t info_nows;
} cdc;

void tud_task_ext(uint32_t timeout_ms, bool in_isr) {
  (void)timeout_ms;
  (void)in_isr;
  cdc.tasks++;
  if (cdc.line_dtr >= 0) {
    const bool dtr = cdc.line_dtr == 1;
    cdc.line_dtr = -1;
    tud_cdc_line_state_cb(0, dtr, false);
  }
}
void skin_fw_info_now(void) { cdc.info_nows++; }
bool tud_cdc_n_connected(uint8_t itf) {
  assert_int_equal(itf, 0);
  return cdc.connected;
}
uint32_t tud_cdc_n_write(uint8_t itf, const void *buf, uint32_t len) {
  assert_int_equal(itf, 0);
  const uint32_t n = len < cdc.room ? len : cdc.room;
  assert_true(cdc.fifo_len + n <= sizeof cdc.fifo);
  memcpy(cdc.fifo + cdc.fifo_len, buf, n);
  cdc.fifo_len += n;
  cdc.room -= n;
  return n;
}
uint32_t tud_cdc_n_write_flush(uint8_t itf) {
  assert_int_equal(itf, 0);
  cdc.flushes++;
  return 0;
}
bool tud_cdc_n_write_clear(uint8_t itf) {
  assert_int_equal(itf, 0);
  cdc.clears++;
  cdc.fifo_len = 0;
  return true;
}

static uint32_t now_us;
uint32_t board_time_us32(void) { return now_us; }

static uint8_t frame[1048];
static uint8_t frame2[1048];

static int setup(void **state) {
  (void)state;
  memset(&cdc, 0, sizeof cdc);
  cdc.connected = true;
  cdc.room = 2048;
  cdc.line_dtr = -1;
  usb_link_reset();
  /* Configured, then the host opens the port and the core waits for a scan tick. */
  tud_mount_cb();
  tud_cdc_line_state_cb(0, true, false);
  usb_link_poll();
  cdc.tasks = cdc.clears = cdc.info_nows = 0;
  usb_link_discarded = 0;
  now_us = 0xFFFF0000u; /* the clock wraps during the tests */
  for (uint32_t i = 0; i < sizeof frame; i++) {
    frame[i] = (uint8_t)(i * 7u + 1u);
    frame2[i] = (uint8_t)(i * 3u + 5u);
  }
  return 0;
}

/* Room for the whole frame: copied and flushed at once, so the core's buffer is free. */
static void frame_fits(void **state) {
  (void)state;
  board_link_send(frame, sizeof frame);
  assert_int_equal(cdc.fifo_len, sizeof frame);
  assert_memory_equal(cdc.fifo, frame, sizeof frame);
  assert_true(cdc.flushes >= 1);
  assert_true(board_link_idle());
}

/* A full FIFO: the frame goes in pieces as the FIFO drains, the link stays busy until the
 * last byte is in, and every poll while the core waits gives the stack the CPU. */
static void frame_in_pieces(void **state) {
  (void)state;
  cdc.room = 100;
  board_link_send(frame, sizeof frame);
  assert_int_equal(cdc.fifo_len, 100);
  uint32_t polls = 0;
  const uint32_t tasks_before = cdc.tasks;
  while (!board_link_idle()) {
    polls++;
    assert_true(polls < 100);
    cdc.room += 300; /* the host took 300 bytes */
  }
  assert_int_equal(cdc.fifo_len, sizeof frame);
  assert_memory_equal(cdc.fifo, frame, sizeof frame);
  assert_int_equal(polls, 4); /* 100 + 4 x 300 >= 1048 */
  assert_int_equal(cdc.tasks - tasks_before, polls + 1);
  assert_int_equal(usb_link_discarded, 0);
}

/* While the core waits for the scan tick the stack runs too. */
static void poll_runs_the_stack(void **state) {
  (void)state;
  usb_link_poll();
  usb_link_poll();
  assert_int_equal(cdc.tasks, 2);
}

/* Nobody has the port open: the frame is discarded, counted, and the link is idle at once, so
 * the scans keep their rate. */
static void no_host_discards(void **state) {
  (void)state;
  cdc.connected = false;
  board_link_send(frame, sizeof frame);
  assert_true(board_link_idle());
  assert_int_equal(cdc.fifo_len, 0);
  assert_int_equal(usb_link_discarded, 1);
}

/* The host closes the port mid-frame and opens it again: the rest of that frame is dropped
 * with what was queued, so the new session's first byte is a frame's first byte. */
static void reopen_starts_on_a_frame(void **state) {
  (void)state;
  tud_cdc_line_state_cb(0, true, true); /* opened */
  cdc.room = 500;
  board_link_send(frame, sizeof frame);
  assert_false(board_link_idle());
  tud_cdc_line_state_cb(0, false, false); /* closed mid-frame */
  assert_int_equal(cdc.fifo_len, 0);
  assert_true(board_link_idle());
  assert_int_equal(usb_link_discarded, 1);

  tud_cdc_line_state_cb(0, true, false);
  usb_link_poll(); /* the scan tick */
  cdc.room = 2048;
  board_link_send(frame2, sizeof frame2);
  assert_true(board_link_idle());
  assert_int_equal(cdc.fifo_len, sizeof frame2);
  assert_memory_equal(cdc.fifo, frame2, sizeof frame2);
}

/* The host opens the port while the core waits for the link (the stack handles the request in
 * that wait): the frame the core sends next, decided before, is discarded; at the next scan
 * tick the port opens, once, with the information frame made due, so the host's first byte
 * is the first of the frame that names the board. Expected: nothing before the tick, one
 * skin_fw_info_now, then the next frame whole at the FIFO's start. */
static void dtr_opens_the_port_at_the_scan_tick_with_the_information_due(void **state) {
  (void)state;
  tud_mount_cb(); /* a new configuration: closed */
  cdc.room = 100;
  board_link_send(frame, sizeof frame); /* closed: discarded at once */
  cdc.line_dtr = 1;
  assert_true(board_link_idle()); /* the stack delivers DTR here */
  assert_int_equal(cdc.line_dtr, -1);
  board_link_send(frame, sizeof frame); /* the frame decided before the port opened */
  assert_true(board_link_idle());
  assert_int_equal(cdc.fifo_len, 0);
  assert_int_equal(cdc.info_nows, 0);
  assert_int_equal(usb_link_discarded, 2);

  usb_link_poll(); /* the core waits for the scan tick: the port opens */
  assert_int_equal(cdc.info_nows, 1);
  board_link_send(frame2, sizeof frame2);
  cdc.room = 2048;
  assert_true(board_link_idle());
  assert_int_equal(cdc.fifo_len, sizeof frame2);
  assert_memory_equal(cdc.fifo, frame2, sizeof frame2);
  usb_link_poll(); /* open already: not a new reader */
  assert_int_equal(cdc.info_nows, 1);

  cdc.line_dtr = 0; /* closed and opened again: a new reader */
  usb_link_poll();
  assert_int_equal(cdc.info_nows, 1);
  cdc.line_dtr = 1; /* delivered in the wait for the tick: opened in it, between two frames */
  usb_link_poll();
  assert_int_equal(cdc.info_nows, 2);
}

/* RTS changing with DTR held (a host setting the lines one request at a time) is the same
 * session: nothing is cleared. */
static void rts_alone_keeps_the_session(void **state) {
  (void)state;
  tud_cdc_line_state_cb(0, true, false);
  const uint32_t clears = cdc.clears;
  board_link_send(frame, sizeof frame);
  tud_cdc_line_state_cb(0, true, true);
  assert_int_equal(cdc.clears, clears);
  assert_int_equal(cdc.fifo_len, sizeof frame);
}

/* A new configuration (bus reset, re-enumeration): the port counts as closed until DTR. */
static void mount_closes_the_session(void **state) {
  (void)state;
  tud_cdc_line_state_cb(0, true, false);
  board_link_send(frame, 10);
  tud_mount_cb();
  assert_int_equal(cdc.fifo_len, 0);
  const uint32_t clears = cdc.clears;
  tud_cdc_line_state_cb(0, true, false); /* DTR after the reset: a new session again */
  assert_int_equal(cdc.clears, clears + 1);
}

/* The port open, nothing read: the frame waits up to USB_LINK_STALL_US, then goes. */
static void host_stopped_reading(void **state) {
  (void)state;
  cdc.room = 100;
  board_link_send(frame, sizeof frame);
  cdc.room = 0;
  now_us += USB_LINK_STALL_US;
  assert_false(board_link_idle()); /* at the bound: still waiting */
  assert_int_equal(usb_link_discarded, 0);
  now_us += 1u;
  assert_true(board_link_idle());
  assert_int_equal(usb_link_discarded, 1);
  assert_int_equal(cdc.fifo_len, 100); /* what was in the FIFO stays: the host may read it */
}

/* A slow reader is not a stopped one: each byte taken restarts the wait. */
static void slow_reader_keeps_the_frame(void **state) {
  (void)state;
  cdc.room = 0;
  board_link_send(frame, sizeof frame);
  uint32_t polls = 0;
  while (!board_link_idle()) {
    assert_true(++polls < 100);
    /* Every other poll the host has taken 64 bytes; the polls between find the FIFO full,
     * 150 % of the bound after the frame was handed but 75 % after the last byte taken. */
    now_us += USB_LINK_STALL_US / 2u + USB_LINK_STALL_US / 4u;
    if (polls % 2u == 0u) {
      cdc.room += 64;
    }
  }
  assert_int_equal(usb_link_discarded, 0);
  assert_int_equal(cdc.fifo_len, sizeof frame);
  assert_memory_equal(cdc.fifo, frame, sizeof frame);
}

/* The core's bound on the transfer ran out first (skin_fw/scan.h): the rest of the frame goes,
 * counted, and the link says no byte was left stuck, so the core does not starve the watchdog
 * over a host that stopped reading. */
static void the_cores_abort_drops_the_rest_without_a_stall(void **state) {
  (void)state;
  cdc.room = 100;
  board_link_send(frame, sizeof frame);
  assert_false(board_link_idle());
  assert_false(board_link_abort());
  assert_true(board_link_idle());
  assert_int_equal(usb_link_discarded, 1);
  assert_int_equal(cdc.fifo_len, 100);
  /* Nothing pending: an abort then has nothing to drop. */
  assert_false(board_link_abort());
  assert_int_equal(usb_link_discarded, 1);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test_setup(frame_fits, setup),
      cmocka_unit_test_setup(frame_in_pieces, setup),
      cmocka_unit_test_setup(poll_runs_the_stack, setup),
      cmocka_unit_test_setup(no_host_discards, setup),
      cmocka_unit_test_setup(reopen_starts_on_a_frame, setup),
      cmocka_unit_test_setup(dtr_opens_the_port_at_the_scan_tick_with_the_information_due, setup),
      cmocka_unit_test_setup(rts_alone_keeps_the_session, setup),
      cmocka_unit_test_setup(mount_closes_the_session, setup),
      cmocka_unit_test_setup(host_stopped_reading, setup),
      cmocka_unit_test_setup(slow_reader_keeps_the_frame, setup),
      cmocka_unit_test_setup(the_cores_abort_drops_the_rest_without_a_stall, setup),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
