#include "reset.h"

#include <stddef.h>

#define RECORD_MAGIC 0x5346AB1Eu

static uint32_t record_check(uint32_t code, uint32_t pc) { return ~(RECORD_MAGIC ^ code ^ pc); }

void nucleo_record_write(volatile nucleo_fault_record_t *record, uint32_t code, uint32_t pc) {
  record->code = code;
  record->pc = pc;
  record->check = record_check(code, pc);
  record->magic = RECORD_MAGIC;
}

uint32_t nucleo_record_take(volatile nucleo_fault_record_t *record, uint32_t csr,
                            uint32_t *pc) {
  const uint32_t code = record->code;
  *pc = record->pc;
  const int valid = record->magic == RECORD_MAGIC && code > NUCLEO_FAULT_NONE &&
                    code < NUCLEO_FAULTS && record->check == record_check(code, *pc);
  record->magic = 0u;
  if (!valid || (csr & NUCLEO_CSR_PORRSTF)) {
    *pc = 0u;
    return NUCLEO_FAULT_NONE;
  }
  return code;
}

const char *nucleo_reset_cause(uint32_t csr) {
  /* Every reset pulls NRST low, so PINRSTF comes with each of the others, and a power-on sets
   * BORRSTF too: the most specific flag names the cause. */
  if (csr & NUCLEO_CSR_LPWRRSTF) {
    return "lpwr";
  }
  if (csr & NUCLEO_CSR_WWDGRSTF) {
    return "wwdg";
  }
  if (csr & NUCLEO_CSR_IWDGRSTF) {
    return "iwdg";
  }
  if (csr & NUCLEO_CSR_SFTRSTF) {
    return "sw";
  }
  if (csr & NUCLEO_CSR_PORRSTF) {
    return "por";
  }
  if (csr & NUCLEO_CSR_BORRSTF) {
    return "bor";
  }
  if (csr & NUCLEO_CSR_PINRSTF) {
    return "pin";
  }
  return "unknown";
}

const char *nucleo_fault_name(uint32_t code) {
  static const char *const names[NUCLEO_FAULTS] = {
      [NUCLEO_FAULT_PLL] = "pll",
      [NUCLEO_FAULT_OVERDRIVE] = "overdrive",
      [NUCLEO_FAULT_FLASH] = "flash",
      [NUCLEO_FAULT_SWITCH] = "switch",
      [NUCLEO_FAULT_HARDFAULT] = "hardfault",
      [NUCLEO_FAULT_MEMMANAGE] = "memmanage",
      [NUCLEO_FAULT_BUSFAULT] = "busfault",
      [NUCLEO_FAULT_USAGEFAULT] = "usagefault",
      [NUCLEO_FAULT_NMI] = "nmi",
      [NUCLEO_FAULT_IRQ] = "irq",
  };
  return code < NUCLEO_FAULTS ? names[code] : NULL;
}
