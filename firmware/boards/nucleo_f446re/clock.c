/*
 * The clock tree: 180 MHz from the ST-LINK's 8 MHz MCO (HSE bypass) through the PLL, with the
 * regulator's over-drive; AHB 180 MHz, APB1 45 MHz, APB2 90 MHz; 5 flash wait states.
 *
 * The HSE is checked: absent at boot (no MCO: SB50 open, an ST-LINK without it) the PLL runs
 * from the internal 16 MHz HSI instead, the same 180 MHz with the HSI's accuracy (about 1 %),
 * and the information frame says clock=hsi. Once the PLL runs from the HSE the clock security
 * system watches it: if it fails the hardware falls back to the HSI and raises an NMI, whose
 * handler relocks the PLL from the HSI (nucleo_clock_hse_lost) and counts hse_lost.
 *
 * Every wait is bounded, counted in polls (the timers do not run yet; skin_fw/wait.h) from the
 * datasheet's times with a margin; a PLL, regulator or flash that does not respond in its bound
 * records the fault and resets the board (fault.c).
 */
#include "nucleo.h"
#include "skin_fw/board.h"
#include "skin_fw/fault.h"
#include "skin_fw/wait.h"

volatile uint32_t nucleo_clock_source;

/* The core runs from the HSI (16 MHz) during every wait below. */
#define HSI_HZ 16000000u
/* HSE: the MCO is a clock signal, ready within a few of its cycles once present; the bound
 * lets an ST-LINK that starts after the MCU at power-up get its MCO going (ST's HAL allows
 * 100 ms for a crystal). A poll here takes about 13 cycles, not the 4 the bound counts, so the
 * waits last up to about 3 times their bound: the watchdog is fed after each step. */
#define HSE_READY_US 20000u
/* PLL lock: the datasheet's tLOCK is at most 300 us at VCO 432 MHz (ST's HAL allows 2 ms). */
#define PLL_READY_US 2000u
/* Over-drive enable and switch: tens of microseconds in the datasheet; 10 ms each. */
#define OVERDRIVE_READY_US 10000u
/* The flash's latency and the clock switch take effect within a few cycles of the bus. */
#define REGISTER_READY_US 100u

static int wait_for(volatile uint32_t *reg, uint32_t mask, uint32_t value, uint32_t us) {
  return skin_wait_bits(reg, mask, value, SKIN_WAIT_POLLS(us, HSI_HZ));
}

/* PLL: VCO input 2 MHz (HSE 8 / 4 or HSI 16 / 8), VCO 2 * 180 = 360 MHz, SYSCLK = VCO / 2. */
#define PLL_N 180u
#define PLL_Q 8u /* 45 MHz on the 48 MHz domain: unused (no USB, no SDIO) but must be 2..15 */
#define PLL_R 2u /* unused (I2S, SAI); must be 2..7 */

static void pll_start(uint32_t source) {
  const uint32_t pll_m = source == RCC_PLLCFGR_PLLSRC_HSE ? 4u : 8u;
  RCC->PLLCFGR = (pll_m << RCC_PLLCFGR_PLLM_Pos) | (PLL_N << RCC_PLLCFGR_PLLN_Pos) |
                 (0u << RCC_PLLCFGR_PLLP_Pos) /* P = 2 */ | source |
                 (PLL_Q << RCC_PLLCFGR_PLLQ_Pos) | (PLL_R << RCC_PLLCFGR_PLLR_Pos);
  RCC->CR |= RCC_CR_PLLON;
  if (!wait_for(&RCC->CR, RCC_CR_PLLRDY, RCC_CR_PLLRDY, PLL_READY_US)) {
    nucleo_fault(NUCLEO_FAULT_PLL);
  }
}

static void switch_to_pll(void) {
  RCC->CFGR = (RCC->CFGR & ~RCC_CFGR_SW) | RCC_CFGR_SW_PLL;
  if (!wait_for(&RCC->CFGR, RCC_CFGR_SWS, RCC_CFGR_SWS_PLL, REGISTER_READY_US)) {
    nucleo_fault(NUCLEO_FAULT_SWITCH);
  }
}

static uint32_t hse_start(void) {
  RCC->CR |= RCC_CR_HSEBYP; /* the MCO is a clock signal, not a crystal */
  RCC->CR |= RCC_CR_HSEON;
  if (wait_for(&RCC->CR, RCC_CR_HSERDY, RCC_CR_HSERDY, HSE_READY_US)) {
    nucleo_clock_source = NUCLEO_CLOCK_HSE_BYPASS;
    return RCC_PLLCFGR_PLLSRC_HSE;
  }
  RCC->CR &= ~RCC_CR_HSEON;
  RCC->CR &= ~RCC_CR_HSEBYP;
  nucleo_clock_source = NUCLEO_CLOCK_HSI_FALLBACK;
  return RCC_PLLCFGR_PLLSRC_HSI;
}

void nucleo_clock_init(void) {
  RCC->APB1ENR |= RCC_APB1ENR_PWREN;
  (void)RCC->APB1ENR;
  /* Voltage scale 1: the only one that allows 180 MHz (with over-drive). Set while the PLL is
   * off, as the reference manual requires. */
  PWR->CR |= PWR_CR_VOS;

  const uint32_t source = hse_start();
  board_watchdog_feed();
  pll_start(source);

  /* Over-drive: needed above 168 MHz; enabled while still running from HSE/HSI. */
  PWR->CR |= PWR_CR_ODEN;
  if (!wait_for(&PWR->CSR, PWR_CSR_ODRDY, PWR_CSR_ODRDY, OVERDRIVE_READY_US)) {
    nucleo_fault(NUCLEO_FAULT_OVERDRIVE);
  }
  PWR->CR |= PWR_CR_ODSWEN;
  if (!wait_for(&PWR->CSR, PWR_CSR_ODSWRDY, PWR_CSR_ODSWRDY, OVERDRIVE_READY_US)) {
    nucleo_fault(NUCLEO_FAULT_OVERDRIVE);
  }
  board_watchdog_feed();

  /* 5 wait states for 150..180 MHz at 2.7..3.6 V, before the clock rises; the read back is
   * how the reference manual says to check that the new latency is in effect. */
  FLASH->ACR = FLASH_ACR_LATENCY_5WS | FLASH_ACR_PRFTEN | FLASH_ACR_ICEN | FLASH_ACR_DCEN;
  if (!wait_for(&FLASH->ACR, FLASH_ACR_LATENCY, FLASH_ACR_LATENCY_5WS, REGISTER_READY_US)) {
    nucleo_fault(NUCLEO_FAULT_FLASH);
  }

  /* AHB /1 = 180 MHz, APB1 /4 = 45 MHz (its maximum), APB2 /2 = 90 MHz (its maximum). */
  RCC->CFGR = (RCC->CFGR & ~(RCC_CFGR_HPRE | RCC_CFGR_PPRE1 | RCC_CFGR_PPRE2)) |
              RCC_CFGR_HPRE_DIV1 | RCC_CFGR_PPRE1_DIV4 | RCC_CFGR_PPRE2_DIV2;
  switch_to_pll();

  if (nucleo_clock_source == NUCLEO_CLOCK_HSE_BYPASS) {
    RCC->CR |= RCC_CR_CSSON; /* an HSE failure from now on raises the NMI */
  }
}

void nucleo_clock_hse_lost(void) {
  /* In the NMI: the system clock is the HSI (16 MHz), the HSE and the PLL are off; the
   * prescalers, wait states and over-drive are as set, so the PLL from the HSI restores the
   * same 180 MHz and every rate derived from it. The frame in flight may go out garbled at the
   * wrong baud for these microseconds: the host counts it as a corrupt frame. */
  skin_fault_count(SKIN_FAULT_HSE_LOST);
  nucleo_clock_source = NUCLEO_CLOCK_HSI_FALLBACK;
  RCC->CR &= ~(RCC_CR_CSSON | RCC_CR_HSEON | RCC_CR_HSEBYP);
  pll_start(RCC_PLLCFGR_PLLSRC_HSI);
  switch_to_pll();
}

const char *nucleo_clock_name(void) {
  return nucleo_clock_source == NUCLEO_CLOCK_HSE_BYPASS ? "hse" : "hsi";
}
