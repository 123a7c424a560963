#include "skin_fw/mux_check.h"

static bool layer_stuck(const uint16_t *counts, uint8_t rows, uint8_t cols) {
  uint16_t largest = 0u;
  for (uint8_t col = 0; col < cols; col++) {
    const uint16_t first = counts[col];
    for (uint8_t row = 1; row < rows; row++) {
      const uint16_t v = counts[(uint32_t)row * cols + col];
      /* A healthy pressed layer differs within its first columns: the loop ends early. */
      if (v > first + SKIN_MUX_NOISE || first > v + SKIN_MUX_NOISE) {
        return false;
      }
    }
    if (first > largest) {
      largest = first;
    }
  }
  return largest > SKIN_MUX_PRESSED;
}

bool skin_mux_stuck(const uint16_t *counts, uint8_t rows, uint8_t cols) {
  if (rows < 2u) {
    return false;
  }
  const uint32_t layer = (uint32_t)rows * cols;
  return layer_stuck(counts, rows, cols) || layer_stuck(counts + layer, rows, cols);
}
