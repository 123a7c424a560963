/* The STM32 CRC unit for the core's frame check (SKIN_FW_CRC32_HW; skin_fw/crc.h). */
#include "nucleo.h"
#include "skin_fw/crc.h"

void nucleo_crc_init(void) {
  RCC->AHB1ENR |= RCC_AHB1ENR_CRCEN;
  (void)RCC->AHB1ENR;
}

void board_crc32_hw_reset(void) { CRC->CR = CRC_CR_RESET; }

/* The unit takes 4 AHB cycles a word; the bus holds the next access until it is done. */
void board_crc32_hw_feed(uint32_t word) { CRC->DR = word; }

uint32_t board_crc32_hw_result(void) { return CRC->DR; }
