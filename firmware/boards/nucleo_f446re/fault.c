/* Stopping on a fault: the reason for a debugger, and a blink code on LD2 when PA5 is free. */
#include "nucleo.h"
#include "skin_fw/board.h"

volatile uint32_t nucleo_fault_code;

static void spin(uint32_t loops) {
  /* Counted loops, not a timer: the clock tree may be the fault. */
  for (volatile uint32_t i = 0; i < loops; i++) {
  }
}

void nucleo_fault(uint32_t code) {
  nucleo_fault_code = code;
  /* No current through the films while stopped. */
  nucleo_gpio_init();
  board_release_rows();
  if (NUCLEO_LED_FREE) {
    nucleo_gpio_output(NUCLEO_LED, 0);
  }
  for (;;) {
    for (uint32_t i = 0; NUCLEO_LED_FREE && i < code; i++) {
      nucleo_gpio_write(NUCLEO_LED, 1);
      spin(400000u);
      nucleo_gpio_write(NUCLEO_LED, 0);
      spin(400000u);
    }
    spin(2000000u);
  }
}
