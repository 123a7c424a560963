#include "skin_fw/fw.h"

#include <string.h>

#include "skin_fw/board.h"
#include "skin_fw/fault.h"
#include "skin_fw/frame.h"
#include "skin_fw/info.h"
#include "skin_fw/scan.h"
#include "skin_fw_config.h"

_Static_assert(SKIN_FW_ROWS >= 1 && SKIN_FW_ROWS <= 128, "SKIN_FW_ROWS must be 1..128");
_Static_assert(SKIN_FW_COLS >= 1 && SKIN_FW_COLS <= 128, "SKIN_FW_COLS must be 1..128");
_Static_assert(SKIN_FW_PITCH_UM > 0, "SKIN_FW_PITCH_UM must be positive");

_Static_assert(SKIN_FW_PROTOCOL == 1 || SKIN_FW_PROTOCOL == 2, "SKIN_FW_PROTOCOL must be 1 or 2");

#ifndef SKIN_FW_INFO_PERIOD_US
#define SKIN_FW_INFO_PERIOD_US 1000000u
#endif

static uint32_t frames[2][SKIN_FRAME_BUFFER_WORDS(SKIN_FW_ROWS, SKIN_FW_COLS)];
/* Sent while the link sends the other: the information frame's text changes with the counters. */
static uint8_t info_frame[SKIN_INFO_MAX_SIZE];
static skin_board_info_t board;
static skin_info_schedule_t info_schedule;
static skin_scan_t scan;

/* Build the information frame with the counters of now and send it; false when the link had
 * stalled (or the text does not fit: nothing sent, which a test of the board would show). */
static bool send_info(void) {
  skin_board_status_t status = {0};
  board_status(&status);
  const uint32_t len = skin_info_build(info_frame, &board, &status, SKIN_FW_VERSION,
                                       SKIN_FW_ROWS, SKIN_FW_COLS, SKIN_FW_PITCH_UM);
  return !len || skin_link_send_when_idle(info_frame, len) != SKIN_LINK_STALLED;
}

/*
 * The fault bits that restate the board's state on every version-2 frame, so they agree with
 * the information frame (docs/protocol.md, "Fault bits"): clock=hsi is SKIN_FAULT_CLOCK and
 * reset=iwdg SKIN_FAULT_WATCHDOG_RESET.
 */
static uint16_t state_faults(void) {
  skin_board_status_t status = {0};
  board_status(&status);
  uint16_t bits = 0u;
  if (status.clock && strcmp(status.clock, "hsi") == 0) {
    bits |= SKIN_FAULT_CLOCK;
  }
  if (status.reset_cause && strcmp(status.reset_cause, "iwdg") == 0) {
    bits |= SKIN_FAULT_WATCHDOG_RESET;
  }
  return bits;
}

void skin_fw_start(void) {
  board = (skin_board_info_t){0};
  skin_faults_clear();
  board_init(&board);
  board_release_rows();
  skin_link_init(board.link_byte_ns);
  skin_scan_init(&scan, frames[0], frames[1], SKIN_FW_ROWS, SKIN_FW_COLS, SKIN_FW_SETTLE_US);
  scan.version = SKIN_FW_PROTOCOL;
  skin_info_schedule_init(&info_schedule, SKIN_FW_INFO_PERIOD_US);
  send_info();
  skin_info_sent(&info_schedule, skin_clock_extend(&scan.clock, board_time_us32()));
  board_watchdog_feed();
}

void skin_fw_step(void) {
  board_wait_scan_tick();
  skin_scan_fault(state_faults());
  const uint32_t len = skin_scan_fill(&scan);
  /* Healthy: the link took what it was given. A row that failed was recovered by the board
     (version 2: marked in its frame; version 1: the scan dropped and counted; the loop goes
     on); a link that stalled was reset, and if
     it stalls scan after scan the watchdog, no longer fed, resets the board. */
  bool healthy = true;
  if (skin_info_due(&info_schedule, scan.last_time_us)) {
    /* Between two data frames: the previous one has left once the link is idle again. */
    healthy = send_info();
    skin_info_sent(&info_schedule, scan.last_time_us);
  }
  if (len && skin_scan_send(&scan, len) == SKIN_LINK_STALLED) {
    healthy = false;
  }
  if (healthy) {
    board_watchdog_feed();
  }
}

void skin_fw_info_now(void) { skin_info_due_now(&info_schedule); }

void skin_fw_run(void) {
  skin_fw_start();
  for (;;) {
    skin_fw_step();
  }
}
