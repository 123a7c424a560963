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
} skin_board_info_t;

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
 * groups, e.g. three at once); the core leaves room for them. Returns when dst is written.
 */
void board_sample_row(uint16_t *dst, uint8_t cols);
#define SKIN_FW_ROW_SLACK 2

/* Block until the scan timer's next tick (the scan rate). */
void board_wait_scan_tick(void);

/*
 * Start sending `len` bytes; the buffer stays untouched until board_link_idle() is true again
 * (a DMA link reads it in the background; a blocking link returns when done).
 */
void board_link_send(const uint8_t *buf, uint32_t len);
bool board_link_idle(void);

#ifdef __cplusplus
}
#endif

#endif
