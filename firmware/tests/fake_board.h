/*
 * A board for the host tests: it records every call of skin_fw/board.h, samples counts that say
 * where they came from, writes garbage into the row slack, and keeps its link busy for a number
 * of polls after each send, as a DMA link would.
 */
#ifndef FAKE_BOARD_H
#define FAKE_BOARD_H

#include <stdbool.h>
#include <stdint.h>

#include "skin_fw/board.h"

enum fake_event_kind { EV_DRIVE, EV_DELAY, EV_SAMPLE, EV_RELEASE, EV_TICK, EV_SEND };

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
  uint8_t fail_layer, fail_row; /* fail_row > 0: row fail_row - 1 of fail_layer fails */
  skin_board_info_t info;
} fake_board_t;

extern fake_board_t fake;

void fake_reset(void);
/* The count the fake samples at (scan, layer, row, col): 12 bits that identify the slot. */
/* Poll the link until its last send has ended (and been copied). */
void fake_drain(void);
uint16_t fake_count(uint32_t scan, uint8_t layer, uint8_t row, uint8_t col);

#endif
