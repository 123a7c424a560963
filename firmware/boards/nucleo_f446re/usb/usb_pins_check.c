/*
 * Compile-time checks of the USB link's pins (skin_board_pins.h, "Link over USB"), beside
 * pins_check.c's: the OTG FS core has its D-/D+ on PA11/PA12 only, and no column, row line or
 * USART pin may take them.
 */
#include "nucleo.h"

_Static_assert(SKIN_BOARD_USB_DM == SKIN_PIN(A, 11) && SKIN_BOARD_USB_DP == SKIN_PIN(A, 12),
               "SKIN_BOARD_USB_DM/DP: the OTG FS core's D-/D+ are PA11/PA12 on the LQFP64");
_Static_assert((NUCLEO_USED_PINS_OR &
                (NUCLEO_BIT(SKIN_BOARD_USB_DM) | NUCLEO_BIT(SKIN_BOARD_USB_DP))) == 0u,
               "PA11/PA12 carry USB: no column, row line or USART pin may use them");
_Static_assert(SKIN_BOARD_USB_SCAN_RATE_HZ >= 1 && SKIN_BOARD_USB_SCAN_RATE_HZ <= 100000 &&
                   1000000 % SKIN_BOARD_USB_SCAN_RATE_HZ == 0,
               "SKIN_BOARD_USB_SCAN_RATE_HZ: a divisor of 1 000 000 (the scan timer counts us)");
