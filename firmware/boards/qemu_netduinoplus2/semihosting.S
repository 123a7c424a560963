/* int32_t semihost_call(uint32_t op, void *arg): op in r0, its block in r1, result in r0. */
  .syntax unified
  .thumb
  .section .text.semihost_call, "ax", %progbits
  .global semihost_call
  .type semihost_call, %function
  .thumb_func
semihost_call:
  bkpt 0xAB
  bx lr
  .size semihost_call, . - semihost_call
