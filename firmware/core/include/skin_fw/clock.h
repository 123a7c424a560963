/*
 * The 64-bit device time from the board's 32-bit microsecond clock: a wrap is seen as a reading
 * below the previous one, so the clock must be read at least once per 2^32 us (71.6 minutes),
 * which the scan loop does many times over.
 */
#ifndef SKIN_FW_CLOCK_H
#define SKIN_FW_CLOCK_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
  uint32_t last;
  uint32_t high;
} skin_clock_t;

void skin_clock_init(skin_clock_t *clock, uint32_t now32);
uint64_t skin_clock_extend(skin_clock_t *clock, uint32_t now32);

#ifdef __cplusplus
}
#endif

#endif
