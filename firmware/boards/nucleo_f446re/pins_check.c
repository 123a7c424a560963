/*
 * Compile-time checks of the wiring in skin_board_pins.h: a table the hardware cannot carry out
 * fails the build here, with the reason, instead of misbehaving on the bench.
 */
#include "nucleo.h"
#include "skin_fw/board.h"
#include "skin_fw/frame.h"

/* ---- Grid ---- */
_Static_assert(SKIN_BOARD_ROWS >= 1 && SKIN_BOARD_ROWS <= 16,
               "SKIN_BOARD_ROWS: 1..16 (a 16:1 mux per layer)");
_Static_assert(SKIN_BOARD_COLS >= 3 && SKIN_BOARD_COLS <= 16,
               "SKIN_BOARD_COLS: 3..16 (one ADC input per column, three ADCs)");
_Static_assert(SKIN_FRAME_V1_SIZE(SKIN_BOARD_ROWS, SKIN_BOARD_COLS) <= 65535u,
               "a frame must fit one DMA transfer (65535 bytes)");

/* The frames and the information frame (at most 206 bytes a second) fit the USART's line (10
 * bits a byte), so that a scan never waits for the link. Not the USB image's: its rate is set against
 * USB's throughput (skin_board_pins.h, "Link over USB"). */
#if SKIN_FW_PROTOCOL == 1
#define SKIN_BOARD_FRAME_BYTES SKIN_FRAME_V1_SIZE(SKIN_BOARD_ROWS, SKIN_BOARD_COLS)
#else
#define SKIN_BOARD_FRAME_BYTES SKIN_FRAME_V2_SIZE(SKIN_BOARD_ROWS, SKIN_BOARD_COLS)
#endif
#ifndef SKIN_FW_LINK_USB
_Static_assert(SKIN_BOARD_SCAN_RATE_HZ * SKIN_BOARD_FRAME_BYTES + 206u <= SKIN_BOARD_BAUD / 10u,
               "SKIN_BOARD_SCAN_RATE_HZ: more frames a second than the link carries");
#endif

/* ---- Timing ---- */
_Static_assert(SKIN_BOARD_ADC_SAMPLE_CYCLES == 3 || SKIN_BOARD_ADC_SAMPLE_CYCLES == 15 ||
                   SKIN_BOARD_ADC_SAMPLE_CYCLES == 28 || SKIN_BOARD_ADC_SAMPLE_CYCLES == 56 ||
                   SKIN_BOARD_ADC_SAMPLE_CYCLES == 84 || SKIN_BOARD_ADC_SAMPLE_CYCLES == 112 ||
                   SKIN_BOARD_ADC_SAMPLE_CYCLES == 144 || SKIN_BOARD_ADC_SAMPLE_CYCLES == 480,
               "SKIN_BOARD_ADC_SAMPLE_CYCLES: one of 3, 15, 28, 56, 84, 112, 144, 480");
_Static_assert(SKIN_BOARD_SETTLE_US >= 0 && SKIN_BOARD_SETTLE_US <= 10000,
               "SKIN_BOARD_SETTLE_US: 0..10000");
_Static_assert(SKIN_BOARD_SCAN_RATE_HZ >= 1 && SKIN_BOARD_SCAN_RATE_HZ <= 100000 &&
                   1000000 % SKIN_BOARD_SCAN_RATE_HZ == 0,
               "SKIN_BOARD_SCAN_RATE_HZ: a divisor of 1 000 000 (the scan timer counts us)");

/* ---- Columns ---- */
#define COLUMN_BIT_OR(c, ch) | (1ul << (c))
#define COLUMN_BIT_ADD(c, ch) + (1ul << (c))
_Static_assert((0ul SKIN_BOARD_COLUMNS(COLUMN_BIT_OR)) == (1ul << SKIN_BOARD_COLS) - 1u &&
                   (0ul SKIN_BOARD_COLUMNS(COLUMN_BIT_ADD)) == (1ul << SKIN_BOARD_COLS) - 1u,
               "SKIN_BOARD_COLUMNS: columns 0..SKIN_BOARD_COLS-1, each exactly once");

#define CHANNEL_OUT_OF_RANGE(c, ch) + ((ch) < 0 || (ch) > 15)
_Static_assert((0 SKIN_BOARD_COLUMNS(CHANNEL_OUT_OF_RANGE)) == 0,
               "SKIN_BOARD_COLUMNS: the LQFP64's ADC inputs are channels 0..15");

#define CHANNEL_OR(c, ch) | (1ul << (ch))
#define CHANNEL_ADD(c, ch) + (1ul << (ch))
_Static_assert((0ul SKIN_BOARD_COLUMNS(CHANNEL_OR)) == (0ul SKIN_BOARD_COLUMNS(CHANNEL_ADD)),
               "SKIN_BOARD_COLUMNS: an ADC channel is used by two columns");

/* ADC3 converts columns 2, 5, 8, ...; on the LQFP64 it reaches IN0..IN3 and IN10..IN13 only. */
#define ADC3_UNREACHABLE(c, ch) + ((c) % 3 == 2 && !((ch) <= 3 || ((ch) >= 10 && (ch) <= 13)))
_Static_assert((0 SKIN_BOARD_COLUMNS(ADC3_UNREACHABLE)) == 0,
               "SKIN_BOARD_COLUMNS: columns 2, 5, 8, 11, 14 are converted by ADC3 and must use "
               "channel 0..3 or 10..13 (PA0..PA3, PC0..PC3)");

/* ---- Rows ---- */
#define ROW_BIT_OR(r, ch) | (1ul << (r))
#define ROW_BIT_ADD(r, ch) + (1ul << (r))
#define MUX_CH_OR(r, ch) | (1ul << (ch))
#define MUX_CH_ADD(r, ch) + (1ul << (ch))
#define MUX_CH_OUT_OF_RANGE(r, ch) + ((ch) < 0 || (ch) > 15)
_Static_assert((0ul SKIN_BOARD_ROW_CHANNELS_TOP(ROW_BIT_OR)) == (1ul << SKIN_BOARD_ROWS) - 1u &&
                   (0ul SKIN_BOARD_ROW_CHANNELS_TOP(ROW_BIT_ADD)) ==
                       (1ul << SKIN_BOARD_ROWS) - 1u,
               "SKIN_BOARD_ROW_CHANNELS_TOP: rows 0..SKIN_BOARD_ROWS-1, each exactly once");
_Static_assert((0ul SKIN_BOARD_ROW_CHANNELS_BOTTOM(ROW_BIT_OR)) ==
                       (1ul << SKIN_BOARD_ROWS) - 1u &&
                   (0ul SKIN_BOARD_ROW_CHANNELS_BOTTOM(ROW_BIT_ADD)) ==
                       (1ul << SKIN_BOARD_ROWS) - 1u,
               "SKIN_BOARD_ROW_CHANNELS_BOTTOM: rows 0..SKIN_BOARD_ROWS-1, each exactly once");
_Static_assert((0 SKIN_BOARD_ROW_CHANNELS_TOP(MUX_CH_OUT_OF_RANGE)) == 0 &&
                   (0 SKIN_BOARD_ROW_CHANNELS_BOTTOM(MUX_CH_OUT_OF_RANGE)) == 0,
               "SKIN_BOARD_ROW_CHANNELS_*: mux channels are 0..15");
_Static_assert((0ul SKIN_BOARD_ROW_CHANNELS_TOP(MUX_CH_OR)) ==
                       (0ul SKIN_BOARD_ROW_CHANNELS_TOP(MUX_CH_ADD)) &&
                   (0ul SKIN_BOARD_ROW_CHANNELS_BOTTOM(MUX_CH_OR)) ==
                       (0ul SKIN_BOARD_ROW_CHANNELS_BOTTOM(MUX_CH_ADD)),
               "SKIN_BOARD_ROW_CHANNELS_*: a mux channel is used by two rows of a layer");

#define PIN_ON_PACKAGE(id) ((id) >= 0 && (id) < 64)
_Static_assert(PIN_ON_PACKAGE(SKIN_BOARD_ROW_ADDR0) && PIN_ON_PACKAGE(SKIN_BOARD_ROW_ADDR1) &&
                   PIN_ON_PACKAGE(SKIN_BOARD_ROW_ADDR2) && PIN_ON_PACKAGE(SKIN_BOARD_ROW_ADDR3) &&
                   PIN_ON_PACKAGE(SKIN_BOARD_ROW_EN_TOP) &&
                   PIN_ON_PACKAGE(SKIN_BOARD_ROW_EN_BOTTOM),
               "row pins: SKIN_PIN(A..D, 0..15)");

/* ---- All pins together ---- */
_Static_assert(NUCLEO_USED_PINS_OR == NUCLEO_USED_PINS_SUM,
               "a pin is used twice (columns' ADC pins, row pins and the link's TX/RX)");

#if SKIN_BOARD_LINK_USART == 2
_Static_assert(((0ull SKIN_BOARD_COLUMNS(NUCLEO_COLUMN_OR)) &
                (NUCLEO_BIT(SKIN_PIN(A, 2)) | NUCLEO_BIT(SKIN_PIN(A, 3)))) == 0u,
               "the USART2 link (the stock virtual COM port) uses PA2/PA3: no column may use "
               "ADC channel 2 or 3; 16 columns need SKIN_BOARD_LINK_USART 1");
#endif

/*
 * Pins the Nucleo-F446RE or this firmware reserves: PA13/PA14 (SWD to the ST-LINK), PA11/PA12
 * (USB FS on the expander's connector), PC13 (user button B1, pulled up), PC14/PC15 (the 32 kHz
 * crystal), and the pins the LQFP64 does not have (PB11: VCAP1; port D but PD2).
 */
#define RESERVED_PINS                                                                     \
  (NUCLEO_BIT(SKIN_PIN(A, 13)) | NUCLEO_BIT(SKIN_PIN(A, 14)) | NUCLEO_BIT(SKIN_PIN(A, 11)) | \
   NUCLEO_BIT(SKIN_PIN(A, 12)) | NUCLEO_BIT(SKIN_PIN(C, 13)) | NUCLEO_BIT(SKIN_PIN(C, 14)) | \
   NUCLEO_BIT(SKIN_PIN(C, 15)) | NUCLEO_BIT(SKIN_PIN(B, 11)) |                             \
   (0xFFFFull << (16 * SKIN_PORT_D) & ~NUCLEO_BIT(SKIN_PIN(D, 2))))
_Static_assert((NUCLEO_USED_PINS_OR & RESERVED_PINS) == 0u,
               "a pin the Nucleo reserves (SWD PA13/PA14, USB PA11/PA12, button PC13, 32 kHz "
               "crystal PC14/PC15) or the LQFP64 lacks (PB11, port D but PD2) is used");

/* ---- The watchdog against the slowest healthy scan loop ---- */
/*
 * One loop: the wait for the scan tick (bounded at two periods, timers.c), the scan, and the two
 * link waits (the information frame's and the data frame's, each at most its bound: twice the
 * bytes' time plus 1 ms, skin_fw/scan.h). It must stay within half the watchdog's shortest
 * timeout (the LSI at its fastest), or a healthy board would be reset.
 */
#define CHECK_PERIOD_US (1000000u / SKIN_BOARD_SCAN_RATE_HZ)
#define CHECK_LINK_US(bytes) (2u * (bytes) * (NUCLEO_LINK_BYTE_NS / 1000u + 1u) + 1000u)
#define CHECK_LOOP_US                                                                    \
  (2u * CHECK_PERIOD_US + 2000u +                                                        \
   CHECK_LINK_US(SKIN_BOARD_FRAME_BYTES) + CHECK_LINK_US(206u))
_Static_assert(2u * CHECK_LOOP_US < NUCLEO_IWDG_SHORTEST_US,
               "SKIN_BOARD_SCAN_RATE_HZ or SKIN_BOARD_BAUD too low: the slowest scan loop would "
               "outlast the watchdog (docs/firmware.md, \"Faults and their bounds\")");
