/*
 * The board interface: everything the firmware core asks of a board, and nothing more.
 *
 * The core (scan sequencing, frames, CRCs, the information frame) has no hardware in it; a
 * board (Nucleo-F446RE, the QEMU netduinoplus2 emulation, the host tests' fake) implements
 * these functions. One scan = for each (layer, row): drive the row, wait its settle time,
 * sample every column of that row into the frame's payload.
 */
#ifndef SKIN_FW_BOARD_H
#define SKIN_FW_BOARD_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* What a board tells the core about itself (constant after board_init). */
typedef struct {
  const char *name;      /* short, lowercase, no ';' or '=' (e.g. "nucleo-f446re") */
  uint8_t uid[12];       /* the MCU's 96-bit unique ID (zeros where there is none) */
  uint32_t scan_rate_hz; /* scans per second the scan timer is set to */
  /* Nanoseconds one byte takes on the link (8N1: 10 bit times); 0 for a link whose send
   * returns when the bytes are gone. The core bounds its wait for the link from it. */
  uint32_t link_byte_ns;
} skin_board_info_t;

/*
 * What the board says of its health in the information frame (docs/protocol.md), read each time
 * the frame is built. NULL: not known, the key is left out.
 */
typedef struct {
  const char *reset_cause; /* por, pin, iwdg, wwdg, sw, lpwr, bor or unknown (docs/firmware.md) */
  const char *fault;       /* what stopped the board before this reset (hardfault, ...); NULL: none */
  const char *clock;       /* the system clock's source: hse, or hsi when the HSE failed */
} skin_board_status_t;

void board_status(skin_board_status_t *status);

/* Restart the independent watchdog's count: the core calls it once per healthy scan. */
void board_watchdog_feed(void);

/* Bring up clocks, pins, the ADCs, the timers and the link; fill *info. */
void board_init(skin_board_info_t *info);

/* Free-running device clock in microseconds (the core extends a 32-bit one to 64 bits). */
uint32_t board_time_us32(void);

/* Drive row `row` of layer `layer` (0 top, 1 bottom) and release every other row. */
void board_drive_row(uint8_t layer, uint8_t row);

/* Release every row of both layers (between scans: no current through the films). */
void board_release_rows(void);

/* Wait `us` microseconds (the settle time after a row is driven). */
void board_delay_us(uint32_t us);

/*
 * Sample every column of the driven row into dst[0..cols-1] (12-bit counts, right-aligned).
 * A board may write up to SKIN_FW_ROW_SLACK counts past dst[cols-1] (its ADCs convert in
 * groups, e.g. three at once); the core leaves room for them. Returns true when dst is written;
 * false when the row failed (an overrun, a conversion that did not end in its bound): the board
 * has counted why (skin_fw/fault.h) and recovered its ADC, and dst holds no counts to send.
 */
bool board_sample_row(uint16_t *dst, uint8_t cols);
#define SKIN_FW_ROW_SLACK 2

/* Block until the scan timer's next tick (the scan rate). */
void board_wait_scan_tick(void);

/*
 * Start sending `len` bytes; the buffer stays untouched until board_link_idle() is true again
 * (a DMA link reads it in the background; a blocking link returns when done).
 */
void board_link_send(const uint8_t *buf, uint32_t len);
bool board_link_idle(void);

/*
 * End the transfer in progress, whose completion did not come in its bound, and leave the link
 * idle and ready to send. Returns true when bytes were left unsent (the transfer stalled: the
 * board reset the link's peripherals), false when every byte had gone and only the completion
 * was missing.
 */
bool board_link_abort(void);

#ifdef __cplusplus
}
#endif

#endif
