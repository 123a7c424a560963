/*
 * The independent watchdog (IWDG), clocked by the LSI: started first thing at boot, fed by the
 * core once per healthy scan (board_watchdog_feed). Whatever the bounded waits do not catch (a
 * core locked up, a wait on a clock that stopped) resets the board within its timeout.
 *
 * Timeout: 250 LSI/32 ticks, 250 ms at the LSI's nominal 32 kHz; the datasheet's LSI runs
 * 17..47 kHz, so 170..470 ms. The slowest healthy scan loop (pins_check.c checks it: two scan
 * periods of tick wait, two link bounds, the scan) stays under half the shortest; after a hang
 * the board resets within 470 ms and sends frames again within 1 s of device time.
 *
 * The watchdog keeps running while a debugger halts the core (the firmware leaves DBGMCU alone,
 * a debug unit an emulator may not model): set DBG_IWDG_STOP from the debugger to halt it too.
 */
#include "nucleo.h"
#include "skin_fw/board.h"
#include "skin_fw/wait.h"

#define IWDG_KEY_START 0xCCCCu
#define IWDG_KEY_ACCESS 0x5555u
#define IWDG_KEY_FEED 0xAAAAu
#define IWDG_PRESCALER_32 3u

/* The prescaler and reload reach the watchdog's domain within 5 of its slow cycles (RM0390,
 * IWDG_SR): 1 ms at 32 kHz / 32, polled from the 16 MHz HSI before the clock tree is set. */
#define IWDG_UPDATE_US 10000u

void nucleo_watchdog_init(void) {
  IWDG->KR = IWDG_KEY_START; /* also starts the LSI */
  IWDG->KR = IWDG_KEY_ACCESS;
  IWDG->PR = IWDG_PRESCALER_32;
  IWDG->RLR = NUCLEO_IWDG_RELOAD - 1u;
  /* Bounded: if the update never completes the watchdog runs with its reset values (the
   * longest timeout, 512 ms at 32 kHz / 4 x 4096) and still resets a hung board. */
  (void)skin_wait_bits(&IWDG->SR, IWDG_SR_PVU | IWDG_SR_RVU, 0u,
                       SKIN_WAIT_POLLS(IWDG_UPDATE_US, 16000000u));
  IWDG->KR = IWDG_KEY_FEED;
}

void board_watchdog_feed(void) { IWDG->KR = IWDG_KEY_FEED; }
