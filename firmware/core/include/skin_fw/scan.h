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

typedef struct {
  uint8_t *buf[2];   /* SKIN_FRAME_BUFFER_WORDS(rows, cols) words each, 4-byte aligned */
  uint8_t rows, cols;
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

/* Wait until the link is idle, send the filled frame and make the other buffer the free one. */
void skin_scan_send(skin_scan_t *s, uint32_t len);

/* Wait until the link is idle, then send len bytes of buf. */
void skin_link_send_when_idle(const uint8_t *buf, uint32_t len);

#ifdef __cplusplus
}
#endif

#endif
