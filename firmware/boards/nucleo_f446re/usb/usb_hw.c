/*
 * The USB link's hardware: the 48 MHz clock from PLLSAI, the OTG FS pins, the OTG core through
 * TinyUSB (VBUS not sensed), its interrupt, and the link's init and poll hooks (nucleo.h).
 */
#include "nucleo.h"
#include "skin_fw/board.h"
#include "tusb.h"
#include "usb_desc.h"
#include "usb_link.h"

/* TinyUSB's STM32 port reads it (the OTG turnaround time depends on the AHB clock). */
uint32_t SystemCoreClock = NUCLEO_SYSCLK_HZ;

/*
 * PLLSAI: the same 2 MHz input as the main PLL (HSE 8 / 4, or HSI 16 / 8; RM0390: VCO input
 * 1..2 MHz, PLLSAIM 2..63), VCO 2 x 96 = 192 MHz (100..432 MHz, PLLSAIN 50..432), P output
 * 192 / 4 = 48 MHz (PLLSAIP 2, 4, 6 or 8), selected as the 48 MHz clock by CK48MSEL. The main
 * PLL's Q output (45 MHz) cannot give it: no integer Q divides its 360 MHz VCO to 48 MHz.
 */
#define PLLSAI_IN_HZ 2000000u
#define PLLSAI_N 96u
#define PLLSAI_P 4u
#define PLLSAI_Q 4u /* SAI clock, unused; must be 2..15 */
_Static_assert(PLLSAI_IN_HZ * PLLSAI_N >= 100000000u && PLLSAI_IN_HZ * PLLSAI_N <= 432000000u,
               "PLLSAI VCO out of 100..432 MHz");
_Static_assert(PLLSAI_IN_HZ * PLLSAI_N / PLLSAI_P == 48000000u, "USB needs exactly 48 MHz");

/* The OTG FS pins on the LQFP64 (datasheet, alternate function AF10). */
#define USB_AF 10u
#define USB_POLLS 200000u /* as clock.c's bounded waits: far beyond the PLL's lock time */

static void clock_48mhz(void) {
  /* PLLSAI shares the main PLL's source; its own divider M gives the same 2 MHz input. */
  const uint32_t pll_m = (RCC->PLLCFGR & RCC_PLLCFGR_PLLM) >> RCC_PLLCFGR_PLLM_Pos;
  RCC->PLLSAICFGR = (pll_m << RCC_PLLSAICFGR_PLLSAIM_Pos) |
                    (PLLSAI_N << RCC_PLLSAICFGR_PLLSAIN_Pos) |
                    ((PLLSAI_P / 2u - 1u) << RCC_PLLSAICFGR_PLLSAIP_Pos) |
                    (PLLSAI_Q << RCC_PLLSAICFGR_PLLSAIQ_Pos);
  RCC->CR |= RCC_CR_PLLSAION;
  uint32_t i = 0;
  while (!(RCC->CR & RCC_CR_PLLSAIRDY) && i < USB_POLLS) {
    i++;
  }
  if (!(RCC->CR & RCC_CR_PLLSAIRDY)) {
    nucleo_fault(NUCLEO_FAULT_PLL);
  }
  RCC->DCKCFGR2 |= RCC_DCKCFGR2_CK48MSEL; /* 48 MHz from PLLSAI_P, not PLL_Q */
}

static void pins(void) {
  nucleo_gpio_af(SKIN_BOARD_USB_DM, USB_AF);
  nucleo_gpio_af(SKIN_BOARD_USB_DP, USB_AF);
}

void nucleo_link_init(void) {
  clock_48mhz();
  pins();
  RCC->AHB2ENR |= RCC_AHB2ENR_OTGFSEN;
  (void)RCC->AHB2ENR;

  uint8_t uid[12];
  const volatile uint8_t *src = (const volatile uint8_t *)UID_BASE;
  for (uint32_t i = 0; i < sizeof uid; i++) {
    uid[i] = src[i];
  }
  usb_desc_set_serial(uid);
  usb_link_reset();

  /* Device, full speed. VBUS is not sensed (CFG_TUD_VBUS_DETECT_HW 0): TinyUSB sets the OTG
   * core's B-session valid override and clears VBUS detection in GCCFG, so PA9 stays free. */
  const tusb_rhport_init_t init = {.role = TUSB_ROLE_DEVICE, .speed = TUSB_SPEED_FULL};
  tusb_init(0, &init); /* enables OTG_FS_IRQn; connects (the DP pull-up) */
}

void nucleo_link_poll(void) { usb_link_poll(); }

/* Packets in and out of the endpoint FIFOs; events for tud_task. */
void OTG_FS_IRQHandler(void) { tud_int_handler(0); }

/* TinyUSB's time base (no RTOS): the microsecond clock, extended past its 32 bits. */
uint32_t tusb_time_millis_api(void) {
  static uint32_t last_us;
  static uint64_t total_us;
  const uint32_t now = board_time_us32();
  total_us += (uint32_t)(now - last_us);
  last_us = now;
  return (uint32_t)(total_us / 1000u);
}
