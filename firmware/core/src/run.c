#include "skin_fw/fw.h"

#include "skin_fw/board.h"
#include "skin_fw/frame.h"
#include "skin_fw/info.h"
#include "skin_fw/scan.h"
#include "skin_fw_config.h"

_Static_assert(SKIN_FW_ROWS >= 1 && SKIN_FW_ROWS <= 128, "SKIN_FW_ROWS must be 1..128");
_Static_assert(SKIN_FW_COLS >= 1 && SKIN_FW_COLS <= 128, "SKIN_FW_COLS must be 1..128");
_Static_assert(SKIN_FW_PITCH_UM > 0, "SKIN_FW_PITCH_UM must be positive");

/* The wire protocol version the board sends: a build option (cmake -DSKIN_FW_PROTOCOL=1). */
#ifndef SKIN_FW_PROTOCOL
#define SKIN_FW_PROTOCOL SKIN_FRAME_VERSION_DEFAULT
#endif
_Static_assert(SKIN_FW_PROTOCOL == 1 || SKIN_FW_PROTOCOL == 2, "SKIN_FW_PROTOCOL must be 1 or 2");

#ifndef SKIN_FW_INFO_PERIOD_US
#define SKIN_FW_INFO_PERIOD_US 1000000u
#endif

static uint32_t frames[2][SKIN_FRAME_BUFFER_WORDS(SKIN_FW_ROWS, SKIN_FW_COLS)];
static uint8_t info_frame[SKIN_INFO_MAX_SIZE];
static uint32_t info_len;
static uint64_t next_info_us;
static skin_scan_t scan;

void skin_fw_start(void) {
  skin_board_info_t board = {0};
  board_init(&board);
  board_release_rows();
  info_len = skin_info_build(info_frame, &board, SKIN_FW_VERSION, SKIN_FW_ROWS, SKIN_FW_COLS,
                             SKIN_FW_PITCH_UM);
  skin_scan_init(&scan, frames[0], frames[1], SKIN_FW_ROWS, SKIN_FW_COLS, SKIN_FW_SETTLE_US);
  scan.version = SKIN_FW_PROTOCOL;
  if (info_len) {
    skin_link_send_when_idle(info_frame, info_len);
  }
  next_info_us = skin_clock_extend(&scan.clock, board_time_us32()) + SKIN_FW_INFO_PERIOD_US;
}

void skin_fw_step(void) {
  board_wait_scan_tick();
  const uint32_t len = skin_scan_fill(&scan);
  if (info_len && scan.last_time_us >= next_info_us) {
    /* Between two data frames: the previous one has left once the link is idle again. */
    skin_link_send_when_idle(info_frame, info_len);
    /* On a fixed schedule of device time: a late scan delays one information frame, not every
       one after it. After a stall of over a period, one frame, not a burst to catch up. */
    next_info_us += SKIN_FW_INFO_PERIOD_US;
    if (next_info_us <= scan.last_time_us) {
      next_info_us = scan.last_time_us + SKIN_FW_INFO_PERIOD_US;
    }
  }
  skin_scan_send(&scan, len);
}

void skin_fw_run(void) {
  skin_fw_start();
  for (;;) {
    skin_fw_step();
  }
}
