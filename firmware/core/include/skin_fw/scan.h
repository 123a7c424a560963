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
 * A row that fails (board_sample_row false; the board has counted why) is never sent as counts.
 * Version 2: its bit in the row map is cleared, its counts are zeroed and the scan goes on; the
 * frame carries the row-failed fault bit and is counted (SKIN_FAULT_FRAME_FLAGGED).
 * Version 1 (no row map): the scan stops there, the rows are released and 0 is returned: the
 * frame is dropped, counted (SKIN_FAULT_FRAME_DROPPED), and takes no sequence number, so the
 * host's sequence gaps remain what the line lost.
 */
uint32_t skin_scan_fill(skin_scan_t *s);

/*
 * For the board, at any time (an interrupt too): fault bits (SKIN_FAULT_* of frame.h) for the
 * next version-2 frame, once. The core adds those it finds itself (frame.h).
 */
void skin_scan_fault(uint16_t bits);

/* How the link's previous transfer ended when the link was wanted again. */
typedef enum {
  SKIN_LINK_DONE,    /* in its bound */
  SKIN_LINK_LATE,    /* not in its bound, but every byte had gone: only its completion was lost */
  SKIN_LINK_STALLED, /* not in its bound with bytes left: aborted, the link's peripherals reset */
} skin_link_wait_t;

/*
 * The bound on one transfer of len bytes, in microseconds of the device clock: the bytes' time
 * on the line (link_byte_ns each) twice over, plus SKIN_LINK_SLACK_US for the DMA's start and
 * the scan tick's granularity. A link that blocks in its send (link_byte_ns 0) gets the slack.
 */
#define SKIN_LINK_MARGIN 2u
#define SKIN_LINK_SLACK_US 1000u
void skin_link_init(uint32_t link_byte_ns);
uint32_t skin_link_bound_us(uint32_t len);

/*
 * Wait until the link is idle, at most the bound of the transfer in progress, then send len
 * bytes of buf. A transfer that outlasts its bound is counted (SKIN_FAULT_LINK_TIMEOUT) and
 * aborted (board_link_abort); the return value says how the previous transfer ended.
 */
skin_link_wait_t skin_link_send_when_idle(const uint8_t *buf, uint32_t len);

/* skin_link_send_when_idle the filled frame, then make the other buffer the free one. */
skin_link_wait_t skin_scan_send(skin_scan_t *s, uint32_t len);

#ifdef __cplusplus
}
#endif

#endif
