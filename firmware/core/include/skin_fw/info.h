/* The board-information frame (docs/protocol.md, "Board information frame"). */
#ifndef SKIN_FW_INFO_H
#define SKIN_FW_INFO_H

#include <stdbool.h>
#include <stdint.h>

#include "skin_fw/board.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SKIN_INFO_VERSION 1u
#define SKIN_INFO_MAX_TEXT 200u
#define SKIN_INFO_MAX_SIZE (SKIN_INFO_MAX_TEXT + 6u)

/*
 * Build the frame into out; return its size, or 0 when the six keys of version 1 would exceed
 * 200 bytes. Characters of the board name outside 0x20..0x7E, and ';' and '=', become '_'.
 *
 * With a status (NULL: none), the board's health follows the six keys: reset, fault, clock
 * (those of the status that are not NULL), then the fault counters (skin_fw/fault.h) by key.
 * A field that does not fit whole in the 200 bytes is left out, never cut.
 */
uint32_t skin_info_build(uint8_t out[SKIN_INFO_MAX_SIZE], const skin_board_info_t *board,
                         const skin_board_status_t *status, const char *fw_version, uint8_t rows,
                         uint8_t cols, uint32_t pitch_um);

/*
 * When the information frame goes out, on a fixed schedule of 64-bit device time: once ahead of
 * the first scan, then ahead of the first scan at or after each period since the last one was
 * due, so that a late scan delays one frame, not every one after it; after a stall of over a
 * period, one frame (not a burst to catch up) and the next a period after it.
 * The simulated board keeps the same schedule through this code (firmware/host).
 */
typedef struct {
  uint64_t due_us;    /* the device time at or after which the next one is due */
  uint64_t period_us;
  uint8_t started;    /* 0: none sent yet, the next scan's is due */
} skin_info_schedule_t;

void skin_info_schedule_init(skin_info_schedule_t *s, uint64_t period_us);
/* Whether an information frame goes ahead of the scan of device time now_us. */
bool skin_info_due(const skin_info_schedule_t *s, uint64_t now_us);
/* Note that one went ahead of the scan of device time now_us. */
void skin_info_sent(skin_info_schedule_t *s, uint64_t now_us);
/*
 * Make one due ahead of the next scan whatever the schedule, as at boot: a reader that has just
 * come (a host opening the USB port) learns the board at once, not up to a period later. The
 * period then counts from that one.
 */
void skin_info_due_now(skin_info_schedule_t *s);

#ifdef __cplusplus
}
#endif

#endif
