/*
 * Rows: each layer's 16 rows behind a 16:1 analog multiplexer; 4 address lines shared by both
 * layers, one enable per layer. A disabled mux leaves its rows high-impedance, so releasing a
 * layer is disabling its mux.
 */
#include "nucleo.h"
#include "skin_fw/board.h"

#define ROW_TO_CHANNEL(row, ch) [row] = (ch),
static const uint8_t row_channel[2][SKIN_BOARD_ROWS] = {
    {SKIN_BOARD_ROW_CHANNELS_TOP(ROW_TO_CHANNEL)},
    {SKIN_BOARD_ROW_CHANNELS_BOTTOM(ROW_TO_CHANNEL)},
};

static const uint8_t addr_pin[4] = {SKIN_BOARD_ROW_ADDR0, SKIN_BOARD_ROW_ADDR1,
                                    SKIN_BOARD_ROW_ADDR2, SKIN_BOARD_ROW_ADDR3};
static const uint8_t enable_pin[2] = {SKIN_BOARD_ROW_EN_TOP, SKIN_BOARD_ROW_EN_BOTTOM};

#define ENABLED (SKIN_BOARD_ROW_EN_ACTIVE_LOW ? 0 : 1)
#define DISABLED (!ENABLED)

void nucleo_rows_init(void) {
  for (uint32_t layer = 0; layer < 2u; layer++) {
    nucleo_gpio_output(enable_pin[layer], DISABLED);
  }
  for (uint32_t i = 0; i < 4u; i++) {
    nucleo_gpio_output(addr_pin[i], 0);
  }
}

void board_release_rows(void) {
  nucleo_gpio_write(enable_pin[0], DISABLED);
  nucleo_gpio_write(enable_pin[1], DISABLED);
}

void board_drive_row(uint8_t layer, uint8_t row) {
  /* Break before make: the address changes while both muxes are off, so no other row of
   * either layer conducts for an instant. */
  board_release_rows();
  if (layer > 1u || row >= SKIN_BOARD_ROWS) {
    return;
  }
  const uint32_t ch = row_channel[layer][row];
  for (uint32_t i = 0; i < 4u; i++) {
    nucleo_gpio_write(addr_pin[i], (int)((ch >> i) & 1u));
  }
  nucleo_gpio_write(enable_pin[layer], ENABLED);
}
