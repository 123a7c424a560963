/*
 * The clock tree: 180 MHz from the ST-LINK's 8 MHz MCO (HSE bypass) through the PLL, with the
 * regulator's over-drive; AHB 180 MHz, APB1 45 MHz, APB2 90 MHz; 5 flash wait states.
 * Every wait is bounded: without the MCO the PLL runs from the internal 16 MHz HSI instead (the
 * same 180 MHz, with the HSI's accuracy, about 1 %); a PLL, regulator or flash that does not
 * respond stops the board with a fault code (fault.c).
 */
#include "nucleo.h"

volatile uint32_t nucleo_clock_source;

/*
 * Polls of a ready flag before giving up. At 16 MHz (the HSI, before the switch) a poll takes a
 * few cycles, so this is tens of milliseconds: far beyond the microseconds to a millisecond
 * the datasheet gives for HSE bypass, PLL lock and over-drive.
 */
#define READY_POLLS 200000u

static int wait_for(volatile uint32_t *reg, uint32_t mask, uint32_t value) {
  for (uint32_t i = 0; i < READY_POLLS; i++) {
    if ((*reg & mask) == value) {
      return 1;
    }
  }
  return 0;
}

/* PLL: VCO input 2 MHz (HSE 8 / 4 or HSI 16 / 8), VCO 2 * 180 = 360 MHz, SYSCLK = VCO / 2. */
#define PLL_N 180u
#define PLL_Q 8u /* 45 MHz on the 48 MHz domain: unused (no USB, no SDIO) but must be 2..15 */
#define PLL_R 2u /* unused (I2S, SAI); must be 2..7 */

void nucleo_clock_init(void) {
  RCC->APB1ENR |= RCC_APB1ENR_PWREN;
  (void)RCC->APB1ENR;
  /* Voltage scale 1: the only one that allows 180 MHz (with over-drive). Set while the PLL is
   * off, as the reference manual requires. */
  PWR->CR |= PWR_CR_VOS;

  uint32_t pll_m;
  uint32_t pll_src;
  RCC->CR |= RCC_CR_HSEBYP; /* the MCO is a clock signal, not a crystal */
  RCC->CR |= RCC_CR_HSEON;
  if (wait_for(&RCC->CR, RCC_CR_HSERDY, RCC_CR_HSERDY)) {
    nucleo_clock_source = NUCLEO_CLOCK_HSE_BYPASS;
    pll_m = 4u;
    pll_src = RCC_PLLCFGR_PLLSRC_HSE;
  } else {
    /* No MCO (solder bridge SB50 open, or an ST-LINK without it): run from the HSI. */
    RCC->CR &= ~RCC_CR_HSEON;
    RCC->CR &= ~RCC_CR_HSEBYP;
    nucleo_clock_source = NUCLEO_CLOCK_HSI_FALLBACK;
    pll_m = 8u;
    pll_src = RCC_PLLCFGR_PLLSRC_HSI;
  }

  RCC->PLLCFGR = (pll_m << RCC_PLLCFGR_PLLM_Pos) | (PLL_N << RCC_PLLCFGR_PLLN_Pos) |
                 (0u << RCC_PLLCFGR_PLLP_Pos) /* P = 2 */ | pll_src |
                 (PLL_Q << RCC_PLLCFGR_PLLQ_Pos) | (PLL_R << RCC_PLLCFGR_PLLR_Pos);
  RCC->CR |= RCC_CR_PLLON;
  if (!wait_for(&RCC->CR, RCC_CR_PLLRDY, RCC_CR_PLLRDY)) {
    nucleo_fault(NUCLEO_FAULT_PLL);
  }

  /* Over-drive: needed above 168 MHz; enabled while still running from HSE/HSI. */
  PWR->CR |= PWR_CR_ODEN;
  if (!wait_for(&PWR->CSR, PWR_CSR_ODRDY, PWR_CSR_ODRDY)) {
    nucleo_fault(NUCLEO_FAULT_OVERDRIVE);
  }
  PWR->CR |= PWR_CR_ODSWEN;
  if (!wait_for(&PWR->CSR, PWR_CSR_ODSWRDY, PWR_CSR_ODSWRDY)) {
    nucleo_fault(NUCLEO_FAULT_OVERDRIVE);
  }

  /* 5 wait states for 150..180 MHz at 2.7..3.6 V, before the clock rises; the read back is
   * how the reference manual says to check that the new latency is in effect. */
  FLASH->ACR = FLASH_ACR_LATENCY_5WS | FLASH_ACR_PRFTEN | FLASH_ACR_ICEN | FLASH_ACR_DCEN;
  if (!wait_for(&FLASH->ACR, FLASH_ACR_LATENCY, FLASH_ACR_LATENCY_5WS)) {
    nucleo_fault(NUCLEO_FAULT_FLASH);
  }

  /* AHB /1 = 180 MHz, APB1 /4 = 45 MHz (its maximum), APB2 /2 = 90 MHz (its maximum). */
  RCC->CFGR = (RCC->CFGR & ~(RCC_CFGR_HPRE | RCC_CFGR_PPRE1 | RCC_CFGR_PPRE2)) |
              RCC_CFGR_HPRE_DIV1 | RCC_CFGR_PPRE1_DIV4 | RCC_CFGR_PPRE2_DIV2;
  RCC->CFGR = (RCC->CFGR & ~RCC_CFGR_SW) | RCC_CFGR_SW_PLL;
  if (!wait_for(&RCC->CFGR, RCC_CFGR_SWS, RCC_CFGR_SWS_PLL)) {
    nucleo_fault(NUCLEO_FAULT_SWITCH);
  }
}
