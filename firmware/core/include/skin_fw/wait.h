/*
 * Bounded waits on a hardware flag, for the boards: nothing the firmware waits for may hang it.
 * Each bound is derived from the work waited for (docs/firmware.md, "Faults and their bounds").
 */
#ifndef SKIN_FW_WAIT_H
#define SKIN_FW_WAIT_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/*
 * Before the device clock runs (the clock tree's start-up) a wait is counted in polls. A poll
 * (load, mask, compare, count, branch) takes at least SKIN_WAIT_POLL_CYCLES core cycles, so
 * SKIN_WAIT_POLLS(us, core_hz) polls last at least `us` microseconds: the bound never ends a
 * wait early, and a slower poll only lengthens it.
 */
#define SKIN_WAIT_POLL_CYCLES 4u
#define SKIN_WAIT_POLLS(us, core_hz) \
  ((uint32_t)(((uint64_t)(us) * ((core_hz) / 1000000u) + SKIN_WAIT_POLL_CYCLES - 1u) / \
              SKIN_WAIT_POLL_CYCLES))

/* Poll until (*reg & mask) == value, at most `polls` times; false when it never was. */
bool skin_wait_bits(const volatile uint32_t *reg, uint32_t mask, uint32_t value,
                    uint32_t polls);

typedef enum {
  SKIN_WAIT_DONE,    /* a `done` bit was set */
  SKIN_WAIT_FAILED,  /* a `fail` bit was set (it wins over done) */
  SKIN_WAIT_TIMEOUT, /* neither within bound_us of the device clock (board_time_us32) */
} skin_wait_t;

/* Poll *reg until a done or a fail bit is set, at most bound_us from now. */
skin_wait_t skin_wait_flags(const volatile uint32_t *reg, uint32_t done, uint32_t fail,
                            uint32_t bound_us);

#ifdef __cplusplus
}
#endif

#endif
