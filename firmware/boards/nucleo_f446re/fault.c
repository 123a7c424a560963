/*
 * Faults that stop the board: the cause goes into a record in RAM that the reset leaves alone
 * (.noinit), the rows are released, and the board resets; the next start reads the record and
 * the reset flags and sends them in the information frame (reset=sw;fault=<name>). A fault
 * never leaves the board spinning: the host hears it again within a second (docs/firmware.md).
 */
#include "nucleo.h"
#include "skin_fw/board.h"

__attribute__((section(".noinit"))) static volatile nucleo_fault_record_t fault_record;

/* What this start found (nucleo_reset_init): for the information frame and a debugger. */
static uint32_t reset_csr;
volatile uint32_t nucleo_fault_code;
volatile uint32_t nucleo_fault_pc;

void nucleo_reset_init(void) {
  reset_csr = RCC->CSR;
  RCC->CSR |= RCC_CSR_RMVF; /* the flags accumulate over resets until cleared */
  uint32_t pc;
  nucleo_fault_code = nucleo_record_take(&fault_record, reset_csr, &pc);
  nucleo_fault_pc = pc;
}

const char *nucleo_reset_cause_name(void) { return nucleo_reset_cause(reset_csr); }

void nucleo_fault_at(uint32_t code, uint32_t pc) {
  __disable_irq();
  nucleo_record_write(&fault_record, code, pc);
  /* No current through the films while the board restarts. */
  nucleo_gpio_init();
  board_release_rows();
  NVIC_SystemReset();
}

void nucleo_fault(uint32_t code) { nucleo_fault_at(code, 0u); }

/*
 * The exception handlers: the stacked frame (MSP or PSP, as EXC_RETURN's bit 2 says) gives the
 * address of the instruction that faulted; then record and reset. A fault so bad that the
 * stacking itself fails locks the core up: the IWDG resets it (reset=iwdg).
 */
void nucleo_exception(const uint32_t *frame, uint32_t code) {
  nucleo_fault_at(code, frame[6]);
}

#define EXCEPTION_HANDLER(name, code)                                                         \
  __attribute__((naked)) void name(void) {                                                   \
    __asm volatile("tst lr, #4\n"                                                             \
                   "ite eq\n"                                                                 \
                   "mrseq r0, msp\n"                                                          \
                   "mrsne r0, psp\n"                                                          \
                   "movs r1, %0\n"                                                            \
                   "b nucleo_exception\n" ::"i"(code));                                       \
  }

EXCEPTION_HANDLER(HardFault_Handler, NUCLEO_FAULT_HARDFAULT)
EXCEPTION_HANDLER(MemManage_Handler, NUCLEO_FAULT_MEMMANAGE)
EXCEPTION_HANDLER(BusFault_Handler, NUCLEO_FAULT_BUSFAULT)
EXCEPTION_HANDLER(UsageFault_Handler, NUCLEO_FAULT_USAGEFAULT)
EXCEPTION_HANDLER(Default_Handler, NUCLEO_FAULT_IRQ)
/* The USB image's (usb/usb_hw.c); elsewhere never enabled, so a fault if it ever fires. */
void OTG_FS_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));

void NMI_Handler(void) {
  /* The clock security system's NMI: the HSE failed; the hardware has switched the system
   * clock to the HSI and stopped the PLL. Anything else raising an NMI is a fault. */
  if (RCC->CIR & RCC_CIR_CSSF) {
    RCC->CIR |= RCC_CIR_CSSC;
    nucleo_clock_hse_lost();
    return;
  }
  nucleo_fault(NUCLEO_FAULT_NMI);
}

/* reset.h spells RM0390's flags without the device header; they must be the header's. */
_Static_assert(NUCLEO_CSR_BORRSTF == RCC_CSR_BORRSTF && NUCLEO_CSR_PINRSTF == RCC_CSR_PINRSTF &&
                   NUCLEO_CSR_PORRSTF == RCC_CSR_PORRSTF && NUCLEO_CSR_SFTRSTF == RCC_CSR_SFTRSTF &&
                   NUCLEO_CSR_IWDGRSTF == RCC_CSR_IWDGRSTF &&
                   NUCLEO_CSR_WWDGRSTF == RCC_CSR_WWDGRSTF &&
                   NUCLEO_CSR_LPWRRSTF == RCC_CSR_LPWRRSTF,
               "reset.h's RCC_CSR flags");
