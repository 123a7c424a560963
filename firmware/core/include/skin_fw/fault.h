/*
 * The fault counters: what went wrong since boot and was recovered, each by name. The board
 * information frame carries them (docs/protocol.md), so the host can tell a sampling fault on
 * the board from noise on the line. The core counts the link's and the scan's; a board counts
 * its ADC's and its clock's (skin_fault_count is safe from an interrupt for a counter that only
 * that interrupt raises).
 */
#ifndef SKIN_FW_FAULT_H
#define SKIN_FW_FAULT_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
  /* Of the two, the information frame carries the one of the protocol version the board sends
   * (SKIN_FW_PROTOCOL): the text has room for one only. */
  SKIN_FAULT_FRAME_DROPPED, /* "drop": a version-1 scan not sent because one of its rows failed */
  SKIN_FAULT_FRAME_FLAGGED, /* "flagged": a version-2 frame sent with a failed row marked */
  SKIN_FAULT_ADC_OVERRUN,   /* "adc_ovr": a row's conversion overran (a count was lost) */
  SKIN_FAULT_ADC_TIMEOUT,   /* "adc_to": a row's conversion or its DMA did not end in its bound */
  SKIN_FAULT_LINK_TIMEOUT,  /* "link_to": a transfer to the host did not end in its bound */
  SKIN_FAULT_HSE_LOST,      /* "hse_lost": the external clock failed while running */
  SKIN_FAULT_MUX_STUCK,     /* "mux": a scan not sent (either version): rows alike, pressed */
  SKIN_FAULTS
} skin_fault_t;

void skin_fault_count(skin_fault_t fault);
uint32_t skin_fault_get(skin_fault_t fault);
/* The information frame's key of a counter ("drop", "adc_ovr", ...). */
const char *skin_fault_key(skin_fault_t fault);
void skin_faults_clear(void);

#ifdef __cplusplus
}
#endif

#endif
