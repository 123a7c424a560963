/*
 * The board interface on QEMU's netduinoplus2 (STM32F405), for end-to-end tests without
 * hardware. QEMU 7.2 emulates USART1 and the general-purpose timers, not the ADC, DMA, GPIO, RCC
 * or CRC unit; so:
 *  - the "ADC" reads pre-rendered scans from the host file scans.bin in QEMU's working directory
 *    over semihosting, when row 0 of the top layer is driven: the scan of the present device
 *    time (scan i covers i / rate .. (i + 1) / rate seconds after start-up, the file looped),
 *    as a real skin samples the touch of the moment; an emulation slower than the rate skips
 *    scans of the file, and the scene's time stays the device time;
 *  - TIM2 is the free-running microsecond clock and times the scan tick; TIM3 interrupts every
 *    millisecond only to wake the core from WFI while it waits (QEMU's update interrupts come
 *    late, so they cannot be the tick themselves: the scene's time would drift from the scans');
 *  - USART1 (QEMU's first -serial) takes each byte within the write to DR, so the link is idle
 *    when a send returns;
 *  - the clock tree is left at reset (a PLL set-up would wait forever on QEMU's missing RCC);
 *  - QEMU 7.2 stubs the RCC and the IWDG (writes ignored, reads 0): no watchdog runs here and
 *    no reset flag can be read, so the information frame says reset=unknown and no clock; the
 *    fault counters are the core's and are sent as on the Nucleo.
 *
 * scans.bin (little-endian): "SKNS", u8 format 1, u8 rows, u8 cols, u8 0, u32 scan rate in Hz,
 * u32 number of scans, then each scan: rows*cols u16 top counts, rows*cols u16 bottom counts.
 * skin_driver/tools/firmware_board.py writes it.
 */
#include <string.h>

#include "semihosting.h"
#include "skin_fw/board.h"
#include "skin_fw_config.h"
#include "stm32f4xx.h"

/* QEMU clocks its STM32F2/F4 timers at 1 GHz whatever the (unemulated) RCC says. */
#define TIMER_INPUT_HZ 1000000000u
#define SCAN_FILE "scans.bin"
#define FILE_HEADER 16u
#define SCAN_COUNTS (2u * SKIN_FW_ROWS * SKIN_FW_COLS)

static int32_t scan_file = -1;
static uint32_t scans_in_file;
static uint32_t next_in_file; /* the scan the file position is at */
static uint32_t scan_rate_hz;
static uint32_t clock_last, clock_high; /* TIM2 extended to 64 bits, as the core does */
/* One scan of both layers, with room for the slack the last row may copy. */
static uint16_t scan_counts[SCAN_COUNTS + SKIN_FW_ROW_SLACK];
static uint8_t driven_layer, driven_row;
static uint32_t period_us, next_tick_us;

static void fail(const char *why) {
  semihost_write0("qemu board: ");
  semihost_write0(why);
  semihost_write0("\n");
  semihost_exit();
}

static uint32_t le32(const uint8_t *p) {
  return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint32_t open_scans(void) {
  uint8_t head[FILE_HEADER];
  scan_file = semihost_open(SCAN_FILE);
  if (scan_file < 0 || semihost_read(scan_file, head, FILE_HEADER) != (int32_t)FILE_HEADER) {
    fail("cannot read " SCAN_FILE " (QEMU needs -semihosting-config enable=on,target=native)");
  }
  if (memcmp(head, "SKNS", 4) != 0 || head[4] != 1u) {
    fail(SCAN_FILE " is not a scan file of format 1");
  }
  if (head[5] != SKIN_FW_ROWS || head[6] != SKIN_FW_COLS) {
    fail(SCAN_FILE " has another grid than this firmware");
  }
  scans_in_file = le32(head + 12);
  if (scans_in_file == 0u) {
    fail(SCAN_FILE " holds no scan");
  }
  const uint32_t rate = le32(head + 8);
  return rate < 1u ? 1u : rate > 100000u ? 100000u : rate;
}

static uint64_t now_us(void) {
  const uint32_t now = TIM2->CNT;
  if (now < clock_last) {
    clock_high++;
  }
  clock_last = now;
  return ((uint64_t)clock_high << 32) | now;
}

static void load_scan_of_now(void) {
  const uint32_t index = (uint32_t)(now_us() * scan_rate_hz / 1000000u % scans_in_file);
  /* Consecutive scans read on without a seek: the usual case when the emulation keeps up. */
  if (index != next_in_file &&
      semihost_seek(scan_file, FILE_HEADER + index * 2u * SCAN_COUNTS) != 0) {
    fail("cannot seek in " SCAN_FILE);
  }
  if (semihost_read(scan_file, scan_counts, 2u * SCAN_COUNTS) != (int32_t)(2u * SCAN_COUNTS)) {
    fail(SCAN_FILE " ends inside a scan");
  }
  next_in_file = index + 1u;
}

void TIM3_IRQHandler(void) { TIM3->SR = 0; }

void board_init(skin_board_info_t *info) {
  const uint32_t rate = open_scans();
  scan_rate_hz = rate;
  info->name = "qemu-netduinoplus2";
  memset(info->uid, 0, sizeof info->uid); /* QEMU has no unique ID */
  info->scan_rate_hz = rate;

  /* Prescaler and reload take effect at the update event the UG bit forces. */
  TIM2->PSC = TIMER_INPUT_HZ / 1000000u - 1u;
  TIM2->ARR = 0xFFFFFFFFu;
  TIM2->EGR = TIM_EGR_UG;
  TIM2->CR1 = TIM_CR1_CEN;

  TIM3->PSC = TIMER_INPUT_HZ / 1000000u - 1u;
  TIM3->ARR = 1000u - 1u;
  TIM3->EGR = TIM_EGR_UG;
  TIM3->SR = 0;
  TIM3->DIER = TIM_DIER_UIE;
  NVIC_EnableIRQ(TIM3_IRQn);
  TIM3->CR1 = TIM_CR1_CEN;

  USART1->CR1 = USART_CR1_UE | USART_CR1_TE;
  period_us = 1000000u / rate;
  next_tick_us = TIM2->CNT + period_us;
}

uint32_t board_time_us32(void) { return TIM2->CNT; }

void board_drive_row(uint8_t layer, uint8_t row) {
  if (layer == 0u && row == 0u) {
    load_scan_of_now();
  }
  driven_layer = layer;
  driven_row = row;
}

void board_release_rows(void) {}

void board_delay_us(uint32_t us) {
  const uint32_t start = TIM2->CNT;
  while (TIM2->CNT - start < us) {
  }
}

bool board_sample_row(uint16_t *dst, uint8_t cols) {
  /* Copy the slack too, as a board converting in groups would: the core must cope with it. */
  const uint16_t *src = scan_counts + ((uint32_t)driven_layer * SKIN_FW_ROWS + driven_row) * cols;
  memcpy(dst, src, 2u * ((uint32_t)cols + SKIN_FW_ROW_SLACK));
  return true;
}

void board_wait_scan_tick(void) {
  for (;;) {
    const int32_t left = (int32_t)(next_tick_us - TIM2->CNT);
    if (left <= 0) {
      break;
    }
    if (left > 2000) {
      __WFI(); /* asleep, QEMU leaves the host's core alone; TIM3 wakes it within 1 ms */
    }
  }
  /* A scan slower than the period (an emulator slower than the rate) starts the next one at
   * once, without a backlog of ticks to catch up with. */
  const uint32_t now = TIM2->CNT;
  next_tick_us = (int32_t)(now - next_tick_us) > (int32_t)period_us ? now + period_us
                                                                      : next_tick_us + period_us;
}

void board_link_send(const uint8_t *buf, uint32_t len) {
  /* QEMU's USART sends each byte inside the write to DR and never clears TXE, so polling TXE
   * only costs: every read of a peripheral takes QEMU's global lock, and that roughly halves
   * the frames per second the emulation reaches. */
  for (uint32_t i = 0; i < len; i++) {
    USART1->DR = buf[i];
  }
}

bool board_link_idle(void) { return true; }

/* Never called: the link is idle whenever a send has returned. */
bool board_link_abort(void) { return false; }

void board_watchdog_feed(void) {}

void board_status(skin_board_status_t *status) { status->reset_cause = "unknown"; }
