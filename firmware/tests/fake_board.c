#include "fake_board.h"

#include "skin_fw/scan.h"

#include <assert.h>
#include <string.h>

#include "skin_fw/fault.h"

fake_board_t fake;

static void record(fake_event_t ev) {
  assert(fake.n_events < FAKE_MAX_EVENTS);
  fake.events[fake.n_events++] = ev;
}

void fake_reset(void) {
  memset(&fake, 0, sizeof fake);
  skin_faults_clear();
  fake.info.name = "fake";
  fake.info.scan_rate_hz = 1000u;
  fake.time_step_us = 1000u;
  for (int i = 0; i < 12; i++) {
    fake.info.uid[i] = (uint8_t)(0x10 * i + 1);
  }
}

uint16_t fake_count(uint32_t scan, uint8_t layer, uint8_t row, uint8_t col) {
  return (uint16_t)((scan * 1931u + layer * 2048u + row * 97u + col) & 0x0FFFu);
}

static void finish_send(void) {
  if (fake.in_flight) {
    assert(fake.n_sent < FAKE_MAX_SENDS && fake.in_flight_len <= FAKE_MAX_SEND_BYTES);
    /* Copied at the end: a core that changed the buffer meanwhile sends what it changed. */
    memcpy(fake.sent[fake.n_sent], fake.in_flight, fake.in_flight_len);
    fake.sent_len[fake.n_sent++] = fake.in_flight_len;
    fake.in_flight = NULL;
  }
}

static bool link_never_completes(void) { return fake.in_flight_fault != 0; }

void board_init(skin_board_info_t *info) { *info = fake.info; }

uint32_t board_time_us32(void) {
  const uint32_t now = fake.time_us32;
  fake.time_us32 += fake.read_us;
  return now;
}

void board_drive_row(uint8_t layer, uint8_t row) {
  if (layer == 0 && row == 0) {
    fake.scans++;
  }
  fake.driven_layer = layer;
  fake.driven_row = row;
  fake.row_driven = true;
  record((fake_event_t){.kind = EV_DRIVE, .layer = layer, .row = row});
}

void board_release_rows(void) {
  fake.row_driven = false;
  record((fake_event_t){.kind = EV_RELEASE});
}

void board_delay_us(uint32_t us) { record((fake_event_t){.kind = EV_DELAY, .value = us}); }

static bool row_fails(void) {
  const uint32_t scan = fake.scans; /* 1 + the scan in progress */
  return fake.fail_scan && fake.driven_layer == fake.fail_layer &&
         fake.driven_row == fake.fail_row &&
         (scan == fake.fail_scan || (fake.fail_persists && scan > fake.fail_scan));
}

bool board_sample_row(uint16_t *dst, uint8_t cols) {
  if (fake.in_flight && (const uint8_t *)dst >= fake.in_flight &&
      (const uint8_t *)dst < fake.in_flight + fake.in_flight_len) {
    fake.samples_into_in_flight++;
  }
  record((fake_event_t){.kind = EV_SAMPLE, .value = cols, .ptr = dst});
  if (row_fails()) {
    /* What an overrun leaves in the row on a board: anything. */
    for (uint8_t c = 0; c < cols + SKIN_FW_ROW_SLACK; c++) {
      dst[c] = 0xFFFFu;
    }
    skin_fault_count(SKIN_FAULT_ADC_OVERRUN);
    return false;
  }
  const uint8_t row = fake.mux_stuck ? fake.mux_stuck_row : fake.driven_row;
  for (uint8_t c = 0; c < cols; c++) {
    const uint16_t count = fake_count(fake.scans - 1u, fake.driven_layer, row, c);
    dst[c] = fake.idle ? (uint16_t)(count & 0x3Fu) : count;
  }
  /* The slack the interface allows, with counts no frame may carry. */
  for (uint8_t s = 0; s < SKIN_FW_ROW_SLACK; s++) {
    dst[cols + s] = 0xFFFFu;
  }
  return true;
}

void board_wait_scan_tick(void) {
  fake.time_us32 += fake.time_step_us;
  record((fake_event_t){.kind = EV_TICK});
}

void board_link_send(const uint8_t *buf, uint32_t len) {
  if (fake.busy_left || fake.in_flight) {
    fake.sends_while_busy++;
  }
  record((fake_event_t){.kind = EV_SEND, .value = len, .ptr = buf});
  fake.in_flight = buf;
  fake.in_flight_len = len;
  fake.in_flight_fault = 0;
  if (fake.link_stalls) {
    fake.link_stalls--;
    fake.in_flight_fault = 1;
  } else if (fake.link_loses_completion) {
    fake.link_loses_completion--;
    fake.in_flight_fault = 2;
  }
  fake.busy_left = fake.busy_polls;
  if (!fake.busy_left && !link_never_completes()) {
    finish_send();
  }
}

bool board_link_idle(void) {
  fake.time_us32 += fake.poll_us;
  if (fake.in_flight && link_never_completes()) {
    return false;
  }
  if (fake.busy_left && --fake.busy_left == 0) {
    finish_send();
  }
  return fake.busy_left == 0;
}

bool board_link_abort(void) {
  record((fake_event_t){.kind = EV_ABORT});
  fake.aborts++;
  const bool bytes_left = fake.in_flight && fake.in_flight_fault == 1;
  fake.in_flight_fault = 0;
  if (bytes_left) {
    fake.cut_sends++;
    fake.in_flight = NULL;
  } else {
    finish_send();
  }
  fake.busy_left = 0;
  return bytes_left;
}

void board_watchdog_feed(void) {
  fake.feeds++;
  record((fake_event_t){.kind = EV_FEED});
}

void board_status(skin_board_status_t *status) { *status = fake.status; }

void fake_drain(void) {
  while (!link_never_completes() && !board_link_idle()) {
  }
}
