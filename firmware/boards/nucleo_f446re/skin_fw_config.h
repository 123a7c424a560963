/* The core's settings for the Nucleo-F446RE, taken from the wiring (skin_board_pins.h). */
#ifndef SKIN_FW_CONFIG_H
#define SKIN_FW_CONFIG_H

#include "skin_board_pins.h"

#define SKIN_FW_ROWS SKIN_BOARD_ROWS
#define SKIN_FW_COLS SKIN_BOARD_COLS
#define SKIN_FW_PITCH_UM SKIN_BOARD_PITCH_UM
#define SKIN_FW_SETTLE_US SKIN_BOARD_SETTLE_US
#define SKIN_FW_VERSION "0.1.0"

#endif
