/*
 * The scan sequencer: one scan of both layers into the frame buffer the link is not sending,
 * then the frame handed to the link (double buffering).
 */
#ifndef SKIN_FW_SCAN_H
#define SKIN_FW_SCAN_H

#include <stdint.h>

#include "skin_fw/clock.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Row-map bytes of one layer for the largest grid a frame can carry (255 rows). */
#define SKIN_SCAN_MAP_MAX 32u

typedef struct {
  uint8_t *buf[2];   /* SKIN_FRAME_BUFFER_WORDS(rows, cols) words each, 4-byte aligned */
  uint8_t version;   /* protocol version of the frames: SKIN_FRAME_VERSION_DEFAULT after init */
  uint8_t rows, cols;
  uint8_t row_map[2u * SKIN_SCAN_MAP_MAX]; /* rows sampled in the newest scan (frame.h) */
  uint32_t settle_us;
  uint32_t seq;      /* of the next frame */
  uint8_t fill;      /* the buffer the next scan fills; the other may still be on the link */
  skin_clock_t clock;
  uint64_t last_time_us; /* device time of the newest scan */
} skin_scan_t;

void skin_scan_init(skin_scan_t *s, uint32_t *buf0, uint32_t *buf1, uint8_t rows, uint8_t cols,
                    uint32_t settle_us);

/*
 * Scan both layers (drive, settle, sample each row; then release) into the free buffer and
 * finish its frame; return the frame's size. The frame is at s->buf[s->fill].
 */
uint32_t skin_scan_fill(skin_scan_t *s);

/*
 * For the board, while board_sample_row() runs: the row being sampled failed, its counts are
 * meaningless. A version-2 frame marks it invalid (and sets SKIN_FAULT_ROW_FAILED); a
 * version-1 frame cannot say so.
 */
void skin_scan_row_failed(void);

/* For the board, at any time (an interrupt too): fault bits (SKIN_FAULT_*) for the next frame. */
void skin_scan_fault(uint16_t bits);

/* Wait until the link is idle, send the filled frame and make the other buffer the free one. */
void skin_scan_send(skin_scan_t *s, uint32_t len);

/* Wait until the link is idle, then send len bytes of buf. */
void skin_link_send_when_idle(const uint8_t *buf, uint32_t len);

#ifdef __cplusplus
}
#endif

#endif
