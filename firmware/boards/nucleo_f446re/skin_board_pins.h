/*
 * How the skin expander is wired to the Nucleo-F446RE: the one file to edit for your expander.
 *
 * THE VALUES BELOW ARE A DEFAULT, NOT THE PAPER'S BOARD: its schematic is not published. They
 * are a layout that fits the Nucleo's Arduino and morpho headers; change them to match yours.
 * Every entry is checked when the firmware compiles (pins_check.c): a pin used twice, a channel
 * an ADC cannot reach, a pin the Nucleo reserves, fails the build with a message.
 * docs/firmware.md walks through each section.
 *
 * The circuit this firmware expects:
 *   - as the paper describes: two FSR layers share 16 column lines, each through its own
 *     amplifier (4 x OPA4354) into an ADC input of the MCU; only the driven layer's row
 *     conducts, the other layer is released;
 *   - this firmware's assumption (the paper does not say how its rows are driven): each layer's
 *     16 rows go through a 16:1 analog multiplexer (74HC4067 / CD74HC4067 style:
 *     4 address lines shared by both layers, one enable line per layer; a disabled mux leaves
 *     all its rows high-impedance). The MCU cannot drive 32 rows directly: the LQFP64 has 50
 *     I/O, 16 of them are the ADC inputs, 2 SWD, 2 the link, 2 the clock input.
 */
#ifndef SKIN_BOARD_PINS_H
#define SKIN_BOARD_PINS_H

/* A GPIO pin: SKIN_PIN(B, 5) is PB5. Ports A..D exist on the LQFP64 (port D: PD2 only). */
#define SKIN_PORT_A 0
#define SKIN_PORT_B 1
#define SKIN_PORT_C 2
#define SKIN_PORT_D 3
#define SKIN_PIN(port, pin) (SKIN_PORT_##port * 16 + (pin))

/* ---- Grid ------------------------------------------------------------------------------- */

#define SKIN_BOARD_ROWS 16       /* rows of each layer, 1..16 (one 16:1 mux per layer) */
#define SKIN_BOARD_COLS 16       /* columns, 3..16: the entries of SKIN_BOARD_COLUMNS */
#define SKIN_BOARD_PITCH_UM 5000 /* taxel pitch; the paper's taxels are about 5 x 5 mm */

/* ---- Timing ----------------------------------------------------------------------------- */

/*
 * Microseconds between driving a row and sampling it: the mux switch, the row's and columns'
 * RC and the amplifiers must settle to 12 bits. 10 us is a margin for ~3.5 kOhm FSRs and
 * ~100 pF of line; measure your expander (docs/firmware.md) and lower it if it settles sooner.
 */
#define SKIN_BOARD_SETTLE_US 10

/*
 * ADC sampling time in ADC clock cycles (22.5 MHz): 3, 15, 28, 56, 84, 112, 144 or 480.
 * The amplifiers drive the inputs with a low impedance; 15 cycles (0.67 us) leaves margin over
 * the minimum of 3.
 */
#define SKIN_BOARD_ADC_SAMPLE_CYCLES 15

/* ---- Columns: column -> ADC channel ----------------------------------------------------- */

/*
 * X(column, channel), one line per column, columns 0..SKIN_BOARD_COLS-1 in order. The channel
 * fixes the pin: IN0..IN7 = PA0..PA7, IN8..IN9 = PB0..PB1, IN10..IN15 = PC0..PC5.
 *
 * The three ADCs convert three columns at once: column c is converted by ADC1 + (c % 3), so
 * columns 2, 5, 8, 11, 14 belong to ADC3, which on the LQFP64 reaches only IN0..IN3 and
 * IN10..IN13 (PA0..PA3, PC0..PC3). The DMA then writes the counts in column order.
 *
 * 16 columns need all 16 ADC inputs, PA2 and PA3 included: on a stock Nucleo these carry the
 * ST-LINK's virtual COM port (USART2, solder bridges SB13/SB14). Hence the default link below
 * is USART1, wired to the ST-LINK (docs/firmware.md, "Link"). PA5 also drives the green LED LD2
 * through SB21: open SB21 so the LED does not load that column's amplifier.
 */
#define SKIN_BOARD_COLUMNS(X)                          \
  X(0, 2)   /* ADC1  PA2  Arduino D1 (SB62 ON)  */     \
  X(1, 3)   /* ADC2  PA3  Arduino D0 (SB63 ON)  */     \
  X(2, 0)   /* ADC3  PA0  Arduino A0            */     \
  X(3, 4)   /* ADC1  PA4  Arduino A2            */     \
  X(4, 5)   /* ADC2  PA5  Arduino D13 (SB21 OFF) */    \
  X(5, 1)   /* ADC3  PA1  Arduino A1            */     \
  X(6, 6)   /* ADC1  PA6  Arduino D12           */     \
  X(7, 7)   /* ADC2  PA7  Arduino D11           */     \
  X(8, 10)  /* ADC3  PC0  Arduino A5            */     \
  X(9, 8)   /* ADC1  PB0  Arduino A3            */     \
  X(10, 9)  /* ADC2  PB1  morpho                */     \
  X(11, 11) /* ADC3  PC1  Arduino A4            */     \
  X(12, 13) /* ADC1  PC3  morpho                */     \
  X(13, 14) /* ADC2  PC4  morpho                */     \
  X(14, 12) /* ADC3  PC2  morpho                */     \
  X(15, 15) /* ADC1  PC5  morpho                */

/* ---- Rows: two 16:1 multiplexers -------------------------------------------------------- */

#define SKIN_BOARD_ROW_ADDR0 SKIN_PIN(B, 5)  /* Arduino D4, mux S0 of both layers */
#define SKIN_BOARD_ROW_ADDR1 SKIN_PIN(B, 4)  /* Arduino D5, mux S1 */
#define SKIN_BOARD_ROW_ADDR2 SKIN_PIN(B, 10) /* Arduino D6, mux S2 */
#define SKIN_BOARD_ROW_ADDR3 SKIN_PIN(A, 8)  /* Arduino D7, mux S3 */
#define SKIN_BOARD_ROW_EN_TOP SKIN_PIN(C, 7)    /* Arduino D9,  enable of the top layer's mux */
#define SKIN_BOARD_ROW_EN_BOTTOM SKIN_PIN(B, 6) /* Arduino D10, enable of the bottom layer's */
#define SKIN_BOARD_ROW_EN_ACTIVE_LOW 1          /* 1: /E as on the 74HC4067; 0: active high */

/*
 * X(row, mux channel) for each layer: which mux input row r of the layer is wired to (the FFC
 * order). Rows 0..SKIN_BOARD_ROWS-1 in order; each channel 0..15 at most once.
 */
#define SKIN_BOARD_ROW_CHANNELS_TOP(X)                                                   \
  X(0, 0) X(1, 1) X(2, 2) X(3, 3) X(4, 4) X(5, 5) X(6, 6) X(7, 7) X(8, 8) X(9, 9)       \
  X(10, 10) X(11, 11) X(12, 12) X(13, 13) X(14, 14) X(15, 15)
#define SKIN_BOARD_ROW_CHANNELS_BOTTOM(X)                                                \
  X(0, 0) X(1, 1) X(2, 2) X(3, 3) X(4, 4) X(5, 5) X(6, 6) X(7, 7) X(8, 8) X(9, 9)       \
  X(10, 10) X(11, 11) X(12, 12) X(13, 13) X(14, 14) X(15, 15)

/* ---- Link to the host ------------------------------------------------------------------- */

/*
 * 1: USART1, TX PA9 (Arduino D8), RX PA10 (Arduino D2), wired to the ST-LINK's virtual COM port
 *    on CN3 with SB13/SB14 opened (UM1724): the default, as 16 columns need PA2/PA3.
 * 2: USART2, TX PA2, RX PA3: the stock Nucleo's virtual COM port, no soldering; then no column
 *    may use IN2/IN3, so at most 14 columns.
 */
#define SKIN_BOARD_LINK_USART 1

/*
 * 921 600 baud: the fastest rate found confirmed on an ST-LINK/V2-1 virtual COM port (sources in
 * docs/firmware.md); it is also the driver's default `baud`. 8N1, no flow control.
 */
#define SKIN_BOARD_BAUD 921600

/*
 * Scans per second. The firmware waits for the link before each frame, so a rate above what the
 * link carries (114 version-2 frames/s of 800 bytes at 921 600 baud, 87 of version 1's 1 048)
 * would only stretch the scans; 100 (80 with version 1) leaves room for the information frame
 * (pins_check.c checks it). 1 000 000 must be a multiple of it.
 */
#if defined(SKIN_FW_PROTOCOL) && SKIN_FW_PROTOCOL == 1
#define SKIN_BOARD_SCAN_RATE_HZ 80
#else
#define SKIN_BOARD_SCAN_RATE_HZ 100
#endif

/* ---- Link over USB (the USB image, skin_fw_nucleo_f446re_usb) ---------------------------- */

/*
 * The expander's USB connector: D- on PA11, D+ on PA12 (OTG_FS_DM/DP, AF10: the only pins of
 * the OTG FS core on the LQFP64), its GND to the Nucleo's GND; VBUS is not sensed (PA9 is
 * USART1's TX) and powers nothing. Checked in usb/usb_pins_check.c.
 */
#define SKIN_BOARD_USB_DM SKIN_PIN(A, 11)
#define SKIN_BOARD_USB_DP SKIN_PIN(A, 12)

/*
 * Scans per second over USB. A version-1 frame of 16 x 16 (1 048 bytes) at 500 scans/s is
 * 524 kB/s, 58 % of the 900 kB/s published for TinyUSB's CDC on an F4 (docs/firmware.md, "What
 * the link carries"); 1 000 needs the smaller version-2 frame.
 */
#define SKIN_BOARD_USB_SCAN_RATE_HZ 500

#ifdef SKIN_FW_LINK_USB
#undef SKIN_BOARD_SCAN_RATE_HZ
#define SKIN_BOARD_SCAN_RATE_HZ SKIN_BOARD_USB_SCAN_RATE_HZ
#endif

#endif
