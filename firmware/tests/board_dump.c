/*
 * board_dump: what the firmware's own main loop (run.c) sends at the scan times on stdin, so that
 * a test can hold the simulated board's information-frame schedule against it.
 *
 * stdin: one device time in microseconds a line, the time of each scan; the first is also the
 * time of the start. stdout: one letter a send, I for an information frame, F for a data frame.
 * The board below is ideal: its link is always idle, its rows always sample.
 */
#include <inttypes.h>
#include <stdio.h>
#include <string.h>

#include "skin_fw/board.h"
#include "skin_fw/fw.h"

static uint32_t now32;

void board_init(skin_board_info_t *info) {
  memset(info, 0, sizeof *info);
  info->name = "dump";
  info->scan_rate_hz = 1000u;
}
uint32_t board_time_us32(void) { return now32; }
void board_drive_row(uint8_t layer, uint8_t row) {
  (void)layer;
  (void)row;
}
void board_release_rows(void) {}
void board_delay_us(uint32_t us) { (void)us; }
bool board_sample_row(uint16_t *dst, uint8_t cols) {
  memset(dst, 0, 2u * (cols + SKIN_FW_ROW_SLACK));
  return true;
}
void board_wait_scan_tick(void) {}
void board_link_send(const uint8_t *buf, uint32_t len) {
  (void)len;
  putchar(buf[1] == 0x69u ? 'I' : 'F');
}
bool board_link_idle(void) { return true; }
bool board_link_abort(void) { return false; }
void board_watchdog_feed(void) {}
void board_status(skin_board_status_t *status) { (void)status; }

int main(void) {
  uint64_t time_us;
  int started = 0;
  while (scanf("%" SCNu64, &time_us) == 1) {
    now32 = (uint32_t)time_us;
    if (!started) {
      skin_fw_start();
      started = 1;
    }
    skin_fw_step();
  }
  putchar('\n');
  return fflush(stdout) == 0 ? 0 : 3;
}
