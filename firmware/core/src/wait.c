#include "skin_fw/wait.h"

#include "skin_fw/board.h"

bool skin_wait_bits(const volatile uint32_t *reg, uint32_t mask, uint32_t value,
                    uint32_t polls) {
  for (uint32_t i = 0; i < polls; i++) {
    if ((*reg & mask) == value) {
      return true;
    }
  }
  return (*reg & mask) == value;
}

skin_wait_t skin_wait_flags(const volatile uint32_t *reg, uint32_t done, uint32_t fail,
                            uint32_t bound_us) {
  const uint32_t start = board_time_us32();
  for (;;) {
    /* The flags before the time: a transfer that ends as the bound runs out still counts. */
    const uint32_t flags = *reg;
    if (flags & fail) {
      return SKIN_WAIT_FAILED;
    }
    if (flags & done) {
      return SKIN_WAIT_DONE;
    }
    if ((uint32_t)(board_time_us32() - start) > bound_us) {
      return SKIN_WAIT_TIMEOUT;
    }
  }
}
