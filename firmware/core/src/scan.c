#include "skin_fw/scan.h"

#include "skin_fw/board.h"
#include "skin_fw/fault.h"
#include "skin_fw/frame.h"
#include "skin_fw/mux_check.h"

/* Set by the board (skin_scan_fault), taken by the scan that follows. */
static volatile uint16_t pending_faults;

void skin_scan_fault(uint16_t bits) { pending_faults |= bits; }

void skin_scan_init(skin_scan_t *s, uint32_t *buf0, uint32_t *buf1, uint8_t rows, uint8_t cols,
                    uint32_t settle_us) {
  s->buf[0] = (uint8_t *)buf0;
  s->buf[1] = (uint8_t *)buf1;
  s->version = SKIN_FRAME_VERSION_DEFAULT;
  s->rows = rows;
  s->cols = cols;
  s->settle_us = settle_us;
  s->seq = 0u;
  s->fill = 0u;
  skin_clock_init(&s->clock, board_time_us32());
  s->last_time_us = 0u;
}

uint32_t skin_scan_fill(skin_scan_t *s) {
  uint8_t *frame = s->buf[s->fill];
  uint16_t *dst = skin_frame_counts(frame, s->version, s->rows);
  const uint32_t map = SKIN_ROW_MAP_BYTES(s->rows);
  for (uint32_t i = 0; i < 2u * map; i++) {
    s->row_map[i] = 0xFFu; /* frame.c clears the spare bits */
  }
  /* The protocol's time is the start of the scan. */
  const uint64_t now = skin_clock_extend(&s->clock, board_time_us32());
  s->last_time_us = now;
  bool flagged = false;
  for (uint8_t layer = 0; layer < 2u; layer++) {
    for (uint8_t row = 0; row < s->rows; row++) {
      board_drive_row(layer, row);
      board_delay_us(s->settle_us);
      /* Rows in order: a row's slack lands on the next row's first counts before they are
       * sampled, and the last row's on the frame check before it is written. */
      if (!board_sample_row(dst, s->cols)) {
        if (s->version == 1u) {
          /* A row without counts: nothing of this scan may be sent as counts (version 1 frames
           * cannot mark a row), and the rest of it would only cost time. */
          board_release_rows();
          skin_fault_count(SKIN_FAULT_FRAME_DROPPED);
          return 0u;
        }
        /* Version 2 marks the row instead. Its counts are zeroed: whatever the failed
         * conversion left there must not look like a sample out of range (SKIN_FAULT_ADC). */
        s->row_map[layer * map + row / 8u] &= (uint8_t)~(1u << (row % 8u));
        for (uint8_t c = 0; c < s->cols; c++) {
          dst[c] = 0u;
        }
        flagged = true;
      }
      dst += s->cols;
    }
  }
  board_release_rows();
  if (skin_mux_stuck(skin_frame_counts(frame, s->version, s->rows), s->rows, s->cols)) {
    /* Valid-looking counts of one row in every row: not sent in either version (a version-2
     * row map cannot say "this row is another row's"). Counted as mux only: drop is the
     * version-1 failed row's counter, and the information frame carries mux in both. No
     * sequence number is taken, and the board's pending fault bits wait for the next frame. */
    skin_fault_count(SKIN_FAULT_MUX_STUCK);
    return 0u;
  }
  /* A fault raised by an interrupt between the read and the clear waits for the next frame. */
  const uint16_t faults = pending_faults;
  pending_faults &= (uint16_t)~faults;
  const skin_frame_meta_t meta = {s->version, s->rows, s->cols, s->seq, now, faults, s->row_map};
  const uint32_t len = skin_frame_finish(frame, &meta);
  if (flagged) {
    skin_fault_count(SKIN_FAULT_FRAME_FLAGGED); /* the frame's SKIN_FAULT_ROW_FAILED bit */
  }
  s->seq++; /* wraps 2^32 - 1 -> 0 as the protocol says */
  return len;
}

/* The transfer in progress: when it started and how long it may take (device-clock us). */
static uint32_t link_byte_ns;
static uint32_t link_started_us;
static uint32_t link_bound_us;

void skin_link_init(uint32_t byte_ns) {
  link_byte_ns = byte_ns;
  link_started_us = 0u;
  link_bound_us = 0u;
}

uint32_t skin_link_bound_us(uint32_t len) {
  const uint64_t ns = (uint64_t)len * link_byte_ns * SKIN_LINK_MARGIN;
  return (uint32_t)((ns + 999u) / 1000u) + SKIN_LINK_SLACK_US;
}

static skin_link_wait_t wait_idle(void) {
  while (!board_link_idle()) {
    if ((uint32_t)(board_time_us32() - link_started_us) > link_bound_us) {
      skin_fault_count(SKIN_FAULT_LINK_TIMEOUT);
      return board_link_abort() ? SKIN_LINK_STALLED : SKIN_LINK_LATE;
    }
  }
  return SKIN_LINK_DONE;
}

skin_link_wait_t skin_link_send_when_idle(const uint8_t *buf, uint32_t len) {
  const skin_link_wait_t previous = wait_idle();
  link_started_us = board_time_us32();
  link_bound_us = skin_link_bound_us(len);
  board_link_send(buf, len);
  return previous;
}

skin_link_wait_t skin_scan_send(skin_scan_t *s, uint32_t len) {
  const skin_link_wait_t previous = skin_link_send_when_idle(s->buf[s->fill], len);
  s->fill ^= 1u;
  return previous;
}
