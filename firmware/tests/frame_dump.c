/*
 * frame_dump: frames made by the core's own scan path from records on stdin, written to stdout,
 * so that a test can hold them byte for byte against Python's wire.encode_frame.
 *
 * Each record (little-endian): u8 rows, u8 cols, u32 seq, u64 device_time_us, then rows*cols
 * top counts and rows*cols bottom counts as u16. The grid is a run-time parameter here; the
 * boards fix theirs at compile time. The "board" below samples the record's counts and fills the
 * row slack with 0xFFFF, as a board may. The protocol version is the argument: 1 or 2 (default 2).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "skin_fw/board.h"
#include "skin_fw/frame.h"
#include "skin_fw/scan.h"

static uint16_t *counts;
static uint8_t cur_rows, cur_cols, cur_layer, cur_row;
static uint32_t now32;

void board_init(skin_board_info_t *info) { (void)info; }
uint32_t board_time_us32(void) { return now32; }
void board_drive_row(uint8_t layer, uint8_t row) {
  cur_layer = layer;
  cur_row = row;
}
void board_release_rows(void) {}
void board_delay_us(uint32_t us) { (void)us; }
bool board_sample_row(uint16_t *dst, uint8_t cols) {
  memcpy(dst, counts + ((size_t)cur_layer * cur_rows + cur_row) * cur_cols, 2u * cols);
  for (int s = 0; s < SKIN_FW_ROW_SLACK; s++) {
    dst[cols + s] = 0xFFFFu;
  }
  return true;
}
void board_wait_scan_tick(void) {}
void board_link_send(const uint8_t *buf, uint32_t len) {
  if (fwrite(buf, 1, len, stdout) != len) {
    exit(3);
  }
}
bool board_link_idle(void) { return true; }
bool board_link_abort(void) { return false; }
void board_watchdog_feed(void) {}
void board_status(skin_board_status_t *status) { (void)status; }

static int read_exact(void *p, size_t n) { return fread(p, 1, n, stdin) == n; }

static uint64_t le(const uint8_t *p, int bytes) {
  uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; i--) {
    v = (v << 8) | p[i];
  }
  return v;
}

int main(int argc, char **argv) {
  const uint8_t version = (argc > 1 && strcmp(argv[1], "1") == 0) ? 1u : 2u;
  if (argc > 1 && strcmp(argv[1], "1") != 0 && strcmp(argv[1], "2") != 0) {
    fprintf(stderr, "frame_dump: the protocol version must be 1 or 2\n");
    return 1;
  }
  static uint32_t buf[2][SKIN_FRAME_BUFFER_WORDS(255, 255)];
  counts = malloc(2u * 2u * 255u * 255u);
  if (!counts) {
    return 2;
  }
  uint8_t head[14];
  while (read_exact(head, sizeof head)) {
    cur_rows = head[0];
    cur_cols = head[1];
    const size_t n = 2u * cur_rows * cur_cols;
    uint8_t *raw = (uint8_t *)counts;
    if (!cur_rows || !cur_cols || !read_exact(raw, 2u * n)) {
      fprintf(stderr, "frame_dump: bad or short record\n");
      return 1;
    }
    for (size_t i = 0; i < n; i++) {
      counts[i] = (uint16_t)le(raw + 2 * i, 2);
    }
    const uint64_t time = le(head + 6, 8);
    /* A fresh sequencer per record, set to the record's seq and time: the clock extension
     * carries the high word, as it would have after that many wraps. */
    skin_scan_t scan;
    now32 = (uint32_t)time;
    skin_scan_init(&scan, buf[0], buf[1], cur_rows, cur_cols, 0u);
    scan.version = version;
    scan.seq = (uint32_t)le(head + 2, 4);
    scan.clock.high = (uint32_t)(time >> 32);
    skin_scan_send(&scan, skin_scan_fill(&scan));
  }
  free(counts);
  return fflush(stdout) == 0 ? 0 : 3;
}
