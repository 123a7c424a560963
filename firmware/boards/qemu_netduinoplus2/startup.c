/*
 * Reset and vectors for the STM32F405 under QEMU: copy .data, clear .bss, enable the FPU (the
 * image is built for the hard-float ABI), call main. Only the TIM3 interrupt is used.
 */
#include <stdint.h>
#include <string.h>

#include "stm32f4xx.h"

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);
void Reset_Handler(void);
void Default_Handler(void);
void TIM3_IRQHandler(void);

typedef void (*handler_t)(void);

/* Vector 1 (reset) onwards; vector 0 is the initial stack pointer. */
struct vector_table {
  void *initial_sp;
  handler_t vectors[16 + 82 - 1];
};

__attribute__((section(".isr_vector"), used)) const struct vector_table vector_table = {
    .initial_sp = &_estack,
    .vectors =
        {
            [0] = Reset_Handler,   [1] = Default_Handler, /* NMI */
            [2] = Default_Handler,                         /* HardFault */
            [3] = Default_Handler, [4] = Default_Handler,  [5] = Default_Handler,
            [10] = Default_Handler, /* SVCall */
            [13] = Default_Handler, /* PendSV */
            [14] = Default_Handler, /* SysTick */
            [15 + TIM3_IRQn] = TIM3_IRQHandler,
        },
};

void Default_Handler(void) {
  for (;;) {
  }
}

void Reset_Handler(void) {
  memcpy(&_sdata, &_sidata, (size_t)((uint8_t *)&_edata - (uint8_t *)&_sdata));
  memset(&_sbss, 0, (size_t)((uint8_t *)&_ebss - (uint8_t *)&_sbss));
  SCB->CPACR |= (3u << 20) | (3u << 22); /* CP10 and CP11: full access */
  __DSB();
  __ISB();
  (void)main();
  for (;;) {
  }
}
