/*
 * A board for the host tests: it records every call of skin_fw/board.h, samples counts that say
 * where they came from, writes garbage into the row slack, and keeps its link busy for a number
 * of polls after each send, as a DMA link would. Its faults, set by a test: a row that fails
 * (as an ADC overrun, counted as the Nucleo counts it), a link whose transfer never completes
 * (stalled with bytes left, or with every byte gone and only the completion lost), a row mux
 * stuck on one row; its clock
 * advances by poll_us at every poll of the link, so a bounded wait can end.
 */
#ifndef FAKE_BOARD_H
#define FAKE_BOARD_H

#include <stdbool.h>
#include <stdint.h>

#include "skin_fw/board.h"

enum fake_event_kind { EV_DRIVE, EV_DELAY, EV_SAMPLE, EV_RELEASE, EV_TICK, EV_SEND, EV_ABORT,
                       EV_FEED };

typedef struct {
  enum fake_event_kind kind;
  uint8_t layer, row;     /* EV_DRIVE */
  uint32_t value;         /* EV_DELAY: us; EV_SAMPLE: cols; EV_SEND: length */
  const void *ptr;        /* EV_SAMPLE: dst; EV_SEND: buffer */
} fake_event_t;

#define FAKE_MAX_EVENTS 4096
#define FAKE_MAX_SENDS 64
#define FAKE_MAX_SEND_BYTES 2048

typedef struct {
  fake_event_t events[FAKE_MAX_EVENTS];
  uint32_t n_events;
  uint8_t sent[FAKE_MAX_SENDS][FAKE_MAX_SEND_BYTES]; /* copies taken when the send ended */
  uint32_t sent_len[FAKE_MAX_SENDS];
  uint32_t n_sent;
  uint32_t time_us32;        /* what board_time_us32 returns */
  uint32_t time_step_us;     /* added to the clock at each scan tick */
  uint32_t busy_polls;       /* polls of board_link_idle a send stays busy for */
  uint32_t busy_left;
  const uint8_t *in_flight;  /* the buffer the link is sending, or NULL */
  uint32_t in_flight_len;
  uint32_t sends_while_busy; /* board_link_send called while not idle: a core bug */
  uint32_t samples_into_in_flight; /* rows sampled into the buffer on the link: a core bug */
  uint8_t driven_layer, driven_row;
  bool row_driven;
  uint32_t scans;            /* drives of layer 0 row 0 so far */
  skin_board_info_t info;
  skin_board_status_t status;
  uint32_t poll_us;          /* device time each poll of board_link_idle takes */
  uint32_t read_us;          /* device time each reading of board_time_us32 takes */
  /* Faults. fail_scan: 1 + the scan (drives of row 0) whose row fail_layer/fail_row fails, and
   * every scan after it while fail_persists; 0: none. */
  uint32_t fail_scan;
  uint8_t fail_layer, fail_row;
  bool fail_persists;
  bool mux_stuck;            /* the row mux selects mux_stuck_row whatever row is driven */
  uint8_t mux_stuck_row;
  bool idle;                 /* the skin untouched: every count below 64 */
  uint32_t link_stalls;      /* so many next transfers never complete: no byte leaves */
  uint32_t link_loses_completion; /* so many next transfers send every byte, never complete */
  int in_flight_fault;       /* the transfer in flight: 0 fine, 1 stalls, 2 loses completion */
  uint32_t aborts;           /* board_link_abort calls */
  uint32_t cut_sends;        /* transfers aborted with bytes left (not in sent[]) */
  uint32_t feeds;            /* board_watchdog_feed calls */
} fake_board_t;

extern fake_board_t fake;

void fake_reset(void);
/* The count the fake samples at (scan, layer, row, col): 12 bits that identify the slot. */
/* Poll the link until its last send has ended (and been copied). */
void fake_drain(void);
uint16_t fake_count(uint32_t scan, uint8_t layer, uint8_t row, uint8_t col);

#endif
