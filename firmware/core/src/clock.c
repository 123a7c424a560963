#include "skin_fw/clock.h"

void skin_clock_init(skin_clock_t *clock, uint32_t now32) {
  clock->last = now32;
  clock->high = 0u;
}

uint64_t skin_clock_extend(skin_clock_t *clock, uint32_t now32) {
  if (now32 < clock->last) {
    clock->high++;
  }
  clock->last = now32;
  return ((uint64_t)clock->high << 32) | now32;
}
