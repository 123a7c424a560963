#include "skin_fw/crc.h"

#include <string.h>

uint16_t skin_crc16(const uint8_t *data, size_t len) {
  /* Bitwise: it covers 18 header bytes or one short information frame, so a table would cost
   * 512 bytes of flash for nothing. */
  uint16_t crc = 0xFFFFu;
  for (size_t i = 0; i < len; i++) {
    crc ^= (uint16_t)((uint16_t)data[i] << 8);
    for (int bit = 0; bit < 8; bit++) {
      crc = (crc & 0x8000u) ? (uint16_t)((crc << 1) ^ 0x1021u) : (uint16_t)(crc << 1);
    }
  }
  return crc;
}

/* One table entry of the reflected polynomial 0xEDB88320, from the bitwise definition. */
static uint32_t crc32_table_entry(uint32_t byte) {
  uint32_t c = byte;
  for (int bit = 0; bit < 8; bit++) {
    c = (c & 1u) ? (c >> 1) ^ 0xEDB88320u : c >> 1;
  }
  return c;
}

static uint32_t crc32_table[256];
static int crc32_table_ready;

static void crc32_make_table(void) {
  /* Built in RAM at first use rather than stored: 1 kB of RAM either way, but nothing to keep
   * in sync by hand. */
  for (uint32_t i = 0; i < 256u; i++) {
    crc32_table[i] = crc32_table_entry(i);
  }
  crc32_table_ready = 1;
}

uint32_t skin_crc32(const uint8_t *data, size_t len) {
  if (!crc32_table_ready) {
    crc32_make_table();
  }
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < len; i++) {
    crc = crc32_table[(crc ^ data[i]) & 0xFFu] ^ (crc >> 8);
  }
  return crc ^ 0xFFFFFFFFu;
}

uint32_t skin_bit_reverse32(uint32_t x) {
#if defined(__ARM_ARCH_7EM__) || defined(__ARM_ARCH_7M__)
  uint32_t r;
  __asm__("rbit %0, %1" : "=r"(r) : "r"(x));
  return r;
#else
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
  x = ((x >> 8) & 0x00FF00FFu) | ((x & 0x00FF00FFu) << 8);
  return (x >> 16) | (x << 16);
#endif
}

uint32_t skin_crc32_words(const uint8_t *data, size_t nwords) {
#ifdef SKIN_FW_CRC32_HW
  /* The unit shifts each word in MSB first without reflection; reversing the bits of the
   * little-endian word presents the bytes LSB first, as ISO-HDLC reads them. */
  board_crc32_hw_reset();
  for (size_t i = 0; i < nwords; i++) {
    uint32_t word;
    memcpy(&word, data + 4u * i, sizeof word);
    board_crc32_hw_feed(skin_bit_reverse32(word));
  }
  return ~skin_bit_reverse32(board_crc32_hw_result());
#else
  return skin_crc32(data, 4u * nwords);
#endif
}
