/* board_init(): the Nucleo-F446RE's parts in the order they depend on each other. */
#include "nucleo.h"
#include "skin_fw/board.h"

void board_init(skin_board_info_t *info) {
  /* Why the board (re)started, before anything can change it; then the watchdog, so that even
   * the start-up cannot hang. */
  nucleo_reset_init();
  nucleo_watchdog_init();
  /* The rows first, released: until then the mux enables float (pull them to "disabled" on the
   * expander), and the clock's bounded waits may take a while without the MCO. */
  nucleo_gpio_init();
  nucleo_rows_init();
  nucleo_clock_init();
  nucleo_timers_init(); /* the ADC's start-up wait uses the microsecond clock */
  nucleo_adc_init();
  nucleo_link_init();
  nucleo_crc_init();

  info->name = "nucleo-f446re";
  /* The 96-bit unique ID, byte by byte as it lies in memory (RM0390, "Unique device ID"). */
  const volatile uint8_t *uid = (const volatile uint8_t *)UID_BASE;
  for (uint32_t i = 0; i < sizeof info->uid; i++) {
    info->uid[i] = uid[i];
  }
  info->scan_rate_hz = SKIN_BOARD_SCAN_RATE_HZ;
  info->link_byte_ns = NUCLEO_LINK_BYTE_NS;
}

void board_status(skin_board_status_t *status) {
  status->reset_cause = nucleo_reset_cause_name();
  status->fault = nucleo_fault_name(nucleo_fault_code);
  status->clock = nucleo_clock_name();
}
