/*
 * The Nucleo-F446RE board's code on QEMU's netduinoplus2 (an STM32F405 with the same memory map
 * for what is used here): what the emulation can show of it. QEMU stores the ADC, timer and
 * USART registers but emulates no multi-ADC mode and no DMA, so the DMA never completes and a
 * row always takes the timeout path: it must come back false, counted, in its bound. Prints key=value lines over semihosting; run.py checks them.
 * The clock tree is left out: QEMU has no RCC (run.py checks the full image's fault instead).
 */
#include <string.h>

#include "nucleo.h"
#include "skin_fw/board.h"
#include "skin_fw/fault.h"

/* clock.c is not linked (QEMU has no RCC); fault.c's NMI handler names these. */
volatile uint32_t nucleo_clock_source;
void nucleo_clock_hse_lost(void) {}

static int semihost(int op, const void *arg) {
  register int r0 __asm__("r0") = op;
  register const void *r1 __asm__("r1") = arg;
  __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}

static void put(const char *key, uint32_t value) {
  char line[48];
  size_t n = strlen(key);
  memcpy(line, key, n);
  line[n++] = '=';
  for (int shift = 28; shift >= 0; shift -= 4) {
    line[n++] = "0123456789abcdef"[(value >> shift) & 15u];
  }
  line[n++] = '\n';
  line[n] = '\0';
  semihost(0x04, line); /* SYS_WRITE0 */
}

static uint16_t row[SKIN_BOARD_COLS + 8];

int main(void) {
  nucleo_gpio_init();
  nucleo_rows_init();
  nucleo_timers_init();
  nucleo_adc_init();
  nucleo_link_init();

  ADC_TypeDef *const adcs[3] = {ADC1, ADC2, ADC3};
  const char *const sqr3[3] = {"adc1_sqr3", "adc2_sqr3", "adc3_sqr3"};
  const char *const sqr1[3] = {"adc1_sqr1", "adc2_sqr1", "adc3_sqr1"};
  for (int i = 0; i < 3; i++) {
    put(sqr3[i], adcs[i]->SQR3);
    put(sqr1[i], adcs[i]->SQR1);
  }
  put("adc1_smpr1", ADC1->SMPR1);
  put("adc1_smpr2", ADC1->SMPR2);
  put("adc1_cr1", ADC1->CR1);
  put("tim2_psc", TIM2->PSC);
  put("tim5_psc", TIM5->PSC);
  put("tim5_arr", TIM5->ARR);
  put("link_brr", SKIN_BOARD_LINK_USART == 1 ? USART1->BRR : USART2->BRR);
  put("link_cr1", SKIN_BOARD_LINK_USART == 1 ? USART1->CR1 : USART2->CR1);
  put("link_cr3", SKIN_BOARD_LINK_USART == 1 ? USART1->CR3 : USART2->CR3);

  memset(row, 0, sizeof row);
  const uint32_t r0 = board_time_us32();
  put("row_sampled", board_sample_row(row, SKIN_BOARD_COLS));
  put("row_took", board_time_us32() - r0);
  put("row_after_slack", row[SKIN_BOARD_COLS + 2]);
  put("adc_timeouts", skin_fault_get(SKIN_FAULT_ADC_TIMEOUT));
  put("adc_overruns", skin_fault_get(SKIN_FAULT_ADC_OVERRUN));

  board_drive_row(1, 5);
  board_release_rows();

  const uint32_t t0 = board_time_us32();
  board_delay_us(100);
  put("delay_100_took", board_time_us32() - t0);
  board_wait_scan_tick();
  put("scan_tick_returned", 1);
  put("done", 1);
  semihost(0x18, (const void *)0x20026); /* SYS_EXIT, ADP_Stopped_ApplicationExit */
  for (;;) {
  }
}
