/*
 * The data frame of docs/protocol.md, built in place: the board samples straight into a
 * 4-byte-aligned buffer, then skin_frame_finish() writes the header, the version-2 body (fault
 * bits, row map, counts packed two in three bytes, in place) and both checks.
 */
#ifndef SKIN_FW_FRAME_H
#define SKIN_FW_FRAME_H

#include <stdint.h>

#include "skin_fw/board.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SKIN_FRAME_HEADER_SIZE 20u
/* Version 1: the header, 2n uint16 counts, the CRC-32. */
#define SKIN_FRAME_V1_SIZE(rows, cols) (24u + 4u * (uint32_t)(rows) * (uint32_t)(cols))
/* Version 2: the header, fault bits, row map, 2n packed counts, padding to words, CRC-32. */
#define SKIN_ROW_MAP_BYTES(rows) (((uint32_t)(rows) + 7u) / 8u)
#define SKIN_FRAME_V2_COUNTS_AT(rows) (22u + 2u * SKIN_ROW_MAP_BYTES(rows))
#define SKIN_FRAME_V2_BODY(rows, cols) \
  (SKIN_FRAME_V2_COUNTS_AT(rows) + 3u * (uint32_t)(rows) * (uint32_t)(cols))
#define SKIN_FRAME_V2_SIZE(rows, cols) ((SKIN_FRAME_V2_BODY(rows, cols) + 3u) / 4u * 4u + 4u)
/*
 * Where a version-2 scan's uint16 samples go: the first word at or after the packed counts, so
 * that packing them forward in place never overwrites a sample not yet packed.
 */
#define SKIN_FRAME_V2_SAMPLES_AT(rows) ((SKIN_FRAME_V2_COUNTS_AT(rows) + 3u) / 4u * 4u)
#define SKIN_FRAME_MAX_(a, b) ((a) > (b) ? (a) : (b))
/*
 * 32-bit words of a frame buffer for either version: the larger frame or the version-2 samples,
 * plus SKIN_FW_ROW_SLACK counts, which the board may write past the last row (over the frame
 * check, written afterwards, and beyond it).
 */
#define SKIN_FRAME_BUFFER_WORDS(rows, cols)                                                      \
  ((SKIN_FRAME_MAX_(SKIN_FRAME_V1_SIZE(rows, cols),                                              \
                    SKIN_FRAME_V2_SAMPLES_AT(rows) + 4u * (uint32_t)(rows) * (uint32_t)(cols)) + \
    2u * SKIN_FW_ROW_SLACK + 3u) /                                                               \
   4u)

/* The version a board sends unless built with SKIN_FW_PROTOCOL=1. */
#define SKIN_FRAME_VERSION_DEFAULT 2u
/* The wire protocol version the board sends: a build option (cmake -DSKIN_FW_PROTOCOL=1). */
#ifndef SKIN_FW_PROTOCOL
#define SKIN_FW_PROTOCOL SKIN_FRAME_VERSION_DEFAULT
#endif

/* Fault bits of a version-2 frame (the board's summary of this scan). */
#define SKIN_FAULT_ROW_FAILED 0x0001u   /* a row failed to sample: the row map marks it */
#define SKIN_FAULT_SCAN_OVERRUN 0x0002u /* the scan started after its tick had passed */
#define SKIN_FAULT_ADC 0x0004u          /* a sample out of 12-bit range (masked when packed) */
#define SKIN_FAULT_CLOCK 0x0008u        /* not running on the crystal */
#define SKIN_FAULT_WATCHDOG_RESET 0x0010u /* the last reset was the watchdog's */

/* Version-2 flags (header byte 3): what the body says, covered by the header check. */
#define SKIN_FLAG_ROWS_INVALID 0x01u
#define SKIN_FLAG_FAULT 0x02u

/* What the frame says besides its counts. */
typedef struct {
  uint8_t version;         /* 1 or 2 */
  uint8_t rows, cols;
  uint32_t seq;
  uint64_t device_time_us;
  uint16_t faults;         /* version 2: SKIN_FAULT_* bits */
  const uint8_t *row_map;  /* version 2: 2 * SKIN_ROW_MAP_BYTES(rows) bytes (top, bottom; bit
                              r % 8 of byte r / 8 is 1 when row r was sampled); NULL: all were */
} skin_frame_meta_t;

/* The first sample of the top layer (uint16); the bottom layer follows the top one's rows*cols. */
static inline uint16_t *skin_frame_counts(uint8_t *frame, uint8_t version, uint8_t rows) {
  return (uint16_t *)(void *)(frame + (version == 1u ? SKIN_FRAME_HEADER_SIZE
                                                      : SKIN_FRAME_V2_SAMPLES_AT(rows)));
}

/* The bytes of a frame of this version and grid. */
uint32_t skin_frame_size(uint8_t version, uint8_t rows, uint8_t cols);

/*
 * Finish the frame whose samples are in place (at skin_frame_counts): write the header, in
 * version 2 the fault bits and row map and the counts packed, and both checks; return its size.
 * Version 1 carries neither fault bits nor a row map (m->faults and m->row_map are ignored).
 */
uint32_t skin_frame_finish(uint8_t *frame, const skin_frame_meta_t *m);

#ifdef __cplusplus
}
#endif

#endif
