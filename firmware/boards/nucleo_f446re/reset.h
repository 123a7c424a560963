/*
 * Why the board last reset, in words the information frame carries (docs/firmware.md, "Reset
 * causes"). Plain C without the device header, so the host tests check it (test_reset.c).
 */
#ifndef NUCLEO_RESET_H
#define NUCLEO_RESET_H

#include <stdint.h>

/* RCC_CSR's reset flags (RM0390, RCC clock control & status register). */
#define NUCLEO_CSR_BORRSTF (1u << 25)
#define NUCLEO_CSR_PINRSTF (1u << 26)
#define NUCLEO_CSR_PORRSTF (1u << 27)
#define NUCLEO_CSR_SFTRSTF (1u << 28)
#define NUCLEO_CSR_IWDGRSTF (1u << 29)
#define NUCLEO_CSR_WWDGRSTF (1u << 30)
#define NUCLEO_CSR_LPWRRSTF (1u << 31)

/* What stopped the board (nucleo_fault): recorded across the reset that follows. */
enum {
  NUCLEO_FAULT_NONE = 0,
  NUCLEO_FAULT_PLL = 1,        /* the PLL did not lock, from the HSE nor from the HSI */
  NUCLEO_FAULT_OVERDRIVE = 2,  /* the regulator's over-drive did not come up */
  NUCLEO_FAULT_FLASH = 3,      /* the flash did not take the wait states */
  NUCLEO_FAULT_SWITCH = 4,     /* the system clock did not switch to the PLL */
  NUCLEO_FAULT_HARDFAULT = 5,  /* the Cortex-M4's fault exceptions ... */
  NUCLEO_FAULT_MEMMANAGE = 6,
  NUCLEO_FAULT_BUSFAULT = 7,
  NUCLEO_FAULT_USAGEFAULT = 8,
  NUCLEO_FAULT_NMI = 9,        /* an NMI other than the clock security system's */
  NUCLEO_FAULT_IRQ = 10,       /* an interrupt the firmware never enables */
  NUCLEO_FAULTS
};

/*
 * The record in RAM that a reset leaves alone (.noinit): a fault's code and the address it
 * happened at, with a check that tells it from the random contents after power-on.
 */
typedef struct {
  uint32_t magic;
  uint32_t code;
  uint32_t pc;
  uint32_t check;
} nucleo_fault_record_t;

void nucleo_record_write(volatile nucleo_fault_record_t *record, uint32_t code, uint32_t pc);

/*
 * The fault recorded before this reset (NUCLEO_FAULT_NONE when there is none, or the reset was
 * a power-on: the RAM's contents are then noise), and the record cleared for the next one.
 */
uint32_t nucleo_record_take(volatile nucleo_fault_record_t *record, uint32_t csr,
                            uint32_t *pc);

/* The reset cause of RCC_CSR's flags: por, bor, pin, sw, iwdg, wwdg, lpwr, or unknown. */
const char *nucleo_reset_cause(uint32_t csr);

/* The information frame's name of a fault code (hardfault, pll, ...); NULL for none. */
const char *nucleo_fault_name(uint32_t code);

#endif
