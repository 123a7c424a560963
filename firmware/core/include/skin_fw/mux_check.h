/*
 * A row multiplexer stuck on one input: every row of its layer reads the same line, so the scan
 * looks valid with one row's counts in every row. While something presses the skin a healthy
 * layer never has all its rows alike (the press is under some rows, not all), so a layer whose
 * rows are all equal within the ADC's noise while its largest count is well above any idle
 * level is taken as a stuck mux. At idle (every count near zero) a stuck mux reads like a
 * healthy skin: it cannot be told there, and nothing is lost by sending such a scan.
 */
#ifndef SKIN_FW_MUX_CHECK_H
#define SKIN_FW_MUX_CHECK_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Counts (12-bit ADC) a row may differ from row 0 by and still be "the same line". */
#define SKIN_MUX_NOISE 16u
/* A layer is pressed when its largest count exceeds this (a quarter of the ADC's range). */
#define SKIN_MUX_PRESSED 1024u

/*
 * True when a layer of the scan (counts: top layer's rows * cols, then the bottom's) has 2 or
 * more rows, all within SKIN_MUX_NOISE of its first at every column, and a count above
 * SKIN_MUX_PRESSED. One row cannot be told from a stuck mux: false.
 */
bool skin_mux_stuck(const uint16_t *counts, uint8_t rows, uint8_t cols);

#ifdef __cplusplus
}
#endif

#endif
