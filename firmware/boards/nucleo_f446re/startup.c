/*
 * Reset and vectors of the STM32F446RE: enable the FPU (the image uses the hard-float ABI), copy
 * .data, clear .bss (not .noinit: the fault record survives resets), call main. No interrupt is
 * enabled (the firmware polls) but the USB image's OTG FS interrupt; the fault exceptions and the
 * NMI have handlers of their own (fault.c: record, reset; the NMI of the clock security system
 * falls back to the HSI), every other vector records an unexpected interrupt and resets.
 */
#include <stdint.h>
#include <string.h>

#include "nucleo.h"

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);
void Reset_Handler(void);
void Default_Handler(void);
/* The USB image's (usb/usb_hw.c); elsewhere Default_Handler (fault.c). */
void OTG_FS_IRQHandler(void);
void NMI_Handler(void);
void HardFault_Handler(void);
void MemManage_Handler(void);
void BusFault_Handler(void);
void UsageFault_Handler(void);

typedef void (*handler_t)(void);

#define IRQS 97 /* WWDG_IRQn (0) .. FMPI2C1_ER_IRQn (96) */

/* Vector 1 (reset) onwards; vector 0 is the initial stack pointer. */
struct vector_table {
  void *initial_sp;
  handler_t vectors[15 + IRQS];
};

#define D Default_Handler
#define D8 D, D, D, D, D, D, D, D
__attribute__((section(".isr_vector"), used)) const struct vector_table vector_table = {
    .initial_sp = &_estack,
    .vectors =
        {
            Reset_Handler, NMI_Handler, HardFault_Handler, MemManage_Handler, BusFault_Handler,
            UsageFault_Handler,
            0, 0, 0, 0,                    /* reserved */
            D, D, 0, D, D,                 /* SVCall, DebugMonitor, reserved, PendSV, SysTick */
            D8, D8, D8, D8, D8, D8, D8, D8,                    /* interrupts 0..63 */
            D, D, D, OTG_FS_IRQHandler, D, D, D, D,            /* 64..71: 67 is OTG FS */
            D8, D8, D8, D,                                     /* 72..96 */
        },
};

void Reset_Handler(void) {
  SCB->CPACR |= (3u << 20) | (3u << 22); /* CP10 and CP11: full access */
  /* The three configurable faults on their own vectors, so the record names them. */
  SCB->SHCSR |= SCB_SHCSR_MEMFAULTENA_Msk | SCB_SHCSR_BUSFAULTENA_Msk | SCB_SHCSR_USGFAULTENA_Msk;
  __DSB();
  __ISB();
  memcpy(&_sdata, &_sidata, (size_t)((uint8_t *)&_edata - (uint8_t *)&_sdata));
  memset(&_sbss, 0, (size_t)((uint8_t *)&_ebss - (uint8_t *)&_sbss));
  (void)main();
  for (;;) {
  }
}
