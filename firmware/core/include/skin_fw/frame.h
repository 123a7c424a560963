/*
 * The data frame of docs/protocol.md, built in place: the board samples straight into the
 * payload of a 4-byte-aligned buffer, then skin_frame_finish() writes the header and both checks.
 */
#ifndef SKIN_FW_FRAME_H
#define SKIN_FW_FRAME_H

#include <stdint.h>

#include "skin_fw/board.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SKIN_FRAME_HEADER_SIZE 20u
#define SKIN_FRAME_SIZE(rows, cols) (24u + 4u * (uint32_t)(rows) * (uint32_t)(cols))
/*
 * 32-bit words of a frame buffer: the frame plus SKIN_FW_ROW_SLACK counts, which the board may
 * write past the last row (over the frame check, written afterwards, and beyond it).
 */
#define SKIN_FRAME_BUFFER_WORDS(rows, cols) \
  ((SKIN_FRAME_SIZE(rows, cols) + 2u * SKIN_FW_ROW_SLACK + 3u) / 4u)

/* The first count of the top layer; the bottom layer follows the top one's rows * cols. */
static inline uint16_t *skin_frame_counts(uint8_t *frame) {
  return (uint16_t *)(void *)(frame + SKIN_FRAME_HEADER_SIZE);
}

/*
 * Write the header (sync, version, flags, seq, time, grid, header check) and the frame check of
 * the frame whose counts are already in place; return its size in bytes.
 */
uint32_t skin_frame_finish(uint8_t *frame, uint8_t rows, uint8_t cols, uint32_t seq,
                           uint64_t device_time_us);

#ifdef __cplusplus
}
#endif

#endif
