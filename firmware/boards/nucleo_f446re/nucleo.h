/*
 * What the Nucleo-F446RE board's files share: the clock tree's frequencies, pin helpers, the
 * link's pins and the init functions board_init() calls.
 */
#ifndef NUCLEO_H
#define NUCLEO_H

#include <stdint.h>

#include "reset.h"
#include "skin_board_pins.h"
#include "stm32f4xx.h"

/* The clock tree nucleo_clock_init() sets up. */
#define NUCLEO_SYSCLK_HZ 180000000u
#define NUCLEO_APB1_HZ 45000000u
#define NUCLEO_APB2_HZ 90000000u
/* With an APB prescaler other than 1 the timers on that bus run at twice its clock. */
#define NUCLEO_APB1_TIMER_HZ (2u * NUCLEO_APB1_HZ)
#define NUCLEO_ADC_HZ (NUCLEO_APB2_HZ / 4u) /* ADCPRE /4: 22.5 MHz, under the 36 MHz maximum */

/* Nanoseconds a byte takes on the line (8N1, 10 bits; the core bounds a transfer from it: twice
 * the bytes' time, skin_fw/scan.h). The USART's rate is within 1 % of this (link.c). */
#define NUCLEO_LINK_BYTE_NS ((uint32_t)((10000000000ull + SKIN_BOARD_BAUD - 1u) / SKIN_BOARD_BAUD))

/* The independent watchdog's reload in ticks of LSI / 32: 250 ms at the LSI's nominal 32 kHz,
 * 170..470 ms over its 17..47 kHz (watchdog.c). */
#define NUCLEO_IWDG_RELOAD 250u
#define NUCLEO_IWDG_SHORTEST_US (NUCLEO_IWDG_RELOAD * 32u * 1000u / 47u)

/* Pin ids as SKIN_PIN() makes them: port * 16 + pin, ports A..D. */
#define NUCLEO_BIT(id) (1ull << (id))
#define NUCLEO_ADC_PIN(ch) \
  ((ch) < 8 ? SKIN_PIN(A, (ch)) : (ch) < 10 ? SKIN_PIN(B, (ch) - 8) : SKIN_PIN(C, (ch) - 10))

/* The link's pins (SKIN_BOARD_LINK_USART). */
#if SKIN_BOARD_LINK_USART == 1
#define NUCLEO_LINK_TX SKIN_PIN(A, 9)
#define NUCLEO_LINK_RX SKIN_PIN(A, 10)
#elif SKIN_BOARD_LINK_USART == 2
#define NUCLEO_LINK_TX SKIN_PIN(A, 2)
#define NUCLEO_LINK_RX SKIN_PIN(A, 3)
#else
#error "SKIN_BOARD_LINK_USART must be 1 (USART1 PA9/PA10) or 2 (USART2 PA2/PA3)"
#endif

/* Every pin the board drives or samples, as a mask and as a sum (equal when none repeats). */
#define NUCLEO_COLUMN_OR(c, ch) | NUCLEO_BIT(NUCLEO_ADC_PIN(ch))
#define NUCLEO_COLUMN_ADD(c, ch) + NUCLEO_BIT(NUCLEO_ADC_PIN(ch))
#define NUCLEO_CONTROL_PINS(op)                                                              \
  (NUCLEO_BIT(SKIN_BOARD_ROW_ADDR0) op NUCLEO_BIT(SKIN_BOARD_ROW_ADDR1) op                   \
       NUCLEO_BIT(SKIN_BOARD_ROW_ADDR2) op NUCLEO_BIT(SKIN_BOARD_ROW_ADDR3) op               \
           NUCLEO_BIT(SKIN_BOARD_ROW_EN_TOP) op NUCLEO_BIT(SKIN_BOARD_ROW_EN_BOTTOM) op      \
               NUCLEO_BIT(NUCLEO_LINK_TX) op NUCLEO_BIT(NUCLEO_LINK_RX))
#define NUCLEO_USED_PINS_OR (NUCLEO_CONTROL_PINS(|) SKIN_BOARD_COLUMNS(NUCLEO_COLUMN_OR))
#define NUCLEO_USED_PINS_SUM (NUCLEO_CONTROL_PINS(+) SKIN_BOARD_COLUMNS(NUCLEO_COLUMN_ADD))

/* GPIO helpers (gpio.c); id as SKIN_PIN() makes it. */
GPIO_TypeDef *nucleo_gpio(uint32_t id);
void nucleo_gpio_init(void);
void nucleo_gpio_output(uint32_t id, int high);
void nucleo_gpio_analog(uint32_t id);
void nucleo_gpio_af(uint32_t id, uint32_t af);
static inline void nucleo_gpio_write(uint32_t id, int high) {
  const uint32_t bit = 1u << (id % 16u);
  nucleo_gpio(id)->BSRR = high ? bit : bit << 16;
}

/*
 * Stop on a fault: record its code (reset.h) in RAM that survives the reset, release the rows,
 * reset. The next start sends the reset cause and the fault in the information frame.
 */
void nucleo_fault(uint32_t code) __attribute__((noreturn));
void nucleo_fault_at(uint32_t code, uint32_t pc) __attribute__((noreturn));
/* Read (and clear) the reset flags and the fault record: first thing at boot. */
void nucleo_reset_init(void);
const char *nucleo_reset_cause_name(void);
/* What the last reset left in the record (also for a debugger). */
extern volatile uint32_t nucleo_fault_code;
extern volatile uint32_t nucleo_fault_pc;

/* The clock source nucleo_clock_init() ended up with; the NMI's fallback when the HSE fails. */
enum { NUCLEO_CLOCK_HSE_BYPASS = 1, NUCLEO_CLOCK_HSI_FALLBACK = 2 };
extern volatile uint32_t nucleo_clock_source;
void nucleo_clock_hse_lost(void);
const char *nucleo_clock_name(void);

/* Link transfers that ended with a DMA error (a debugger reads it). */
extern volatile uint32_t nucleo_link_errors;

void nucleo_watchdog_init(void);
void nucleo_clock_init(void);
void nucleo_timers_init(void);
void nucleo_rows_init(void);
void nucleo_adc_init(void);
void nucleo_link_init(void);
/* Called while the core waits for the scan tick: the USB link runs its stack there. */
void nucleo_link_poll(void);
void nucleo_crc_init(void);

#endif
