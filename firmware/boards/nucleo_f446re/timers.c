/*
 * Time: TIM2 (32 bits) counts microseconds freely, the device clock of the frames and of every
 * delay; TIM5 (32 bits) overflows at the scan rate and paces the scans.
 */
#include "nucleo.h"
#include "skin_fw/board.h"

#define TICK_HZ 1000000u
#define SCAN_PERIOD_US (TICK_HZ / SKIN_BOARD_SCAN_RATE_HZ)

void nucleo_timers_init(void) {
  RCC->APB1ENR |= RCC_APB1ENR_TIM2EN | RCC_APB1ENR_TIM5EN;
  (void)RCC->APB1ENR;

  TIM2->PSC = NUCLEO_APB1_TIMER_HZ / TICK_HZ - 1u;
  TIM2->ARR = 0xFFFFFFFFu;
  TIM2->EGR = TIM_EGR_UG; /* loads the prescaler now rather than at the first overflow */
  TIM2->CR1 = TIM_CR1_CEN;

  TIM5->PSC = NUCLEO_APB1_TIMER_HZ / TICK_HZ - 1u;
  TIM5->ARR = SCAN_PERIOD_US - 1u;
  TIM5->EGR = TIM_EGR_UG;
  TIM5->SR = 0u; /* UG set the update flag; the first tick is one period from now */
  TIM5->CR1 = TIM_CR1_CEN;
}

uint32_t board_time_us32(void) { return TIM2->CNT; }

void board_delay_us(uint32_t us) {
  if (us == 0u) {
    return;
  }
  /* "<=": the first increment may come at once, so waiting for us + 1 of them guarantees at
   * least us microseconds. */
  const uint32_t start = TIM2->CNT;
  while ((uint32_t)(TIM2->CNT - start) <= us) {
  }
}

void board_wait_scan_tick(void) {
  /* The flag stays set when a scan overran its period: the next scan starts at once and the
   * missed ticks are not made up. Bounded by two periods in case the timer was stopped. The link
   * is polled once even then: the USB link opens a port between scans only here. */
  const uint32_t start = TIM2->CNT;
  do {
    nucleo_link_poll();
  } while (!(TIM5->SR & TIM_SR_UIF) && (uint32_t)(TIM2->CNT - start) <= 2u * SCAN_PERIOD_US);
  TIM5->SR = ~TIM_SR_UIF; /* rc_w0: zero clears the flag, ones leave the others */
}
