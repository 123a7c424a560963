/*
 * The two checks of the wire protocol (docs/protocol.md):
 * CRC-16/CCITT-FALSE for the header and the information frame, CRC-32/ISO-HDLC (zlib's) for
 * the whole frame.
 *
 * The CRC-32 runs from a 1 kB table by default. A board with the STM32F1/F4 CRC unit builds the
 * core with SKIN_FW_CRC32_HW defined and provides the three board_crc32_hw_* functions below;
 * that unit computes the non-reflected CRC-32 (MSB first, init 0xFFFFFFFF, no final XOR) of
 * 32-bit words, so the core feeds it bit-reversed words and bit-reverses and inverts its result.
 */
#ifndef SKIN_FW_CRC_H
#define SKIN_FW_CRC_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

uint16_t skin_crc16(const uint8_t *data, size_t len);
uint32_t skin_crc32(const uint8_t *data, size_t len);

/* CRC-32 of nwords little-endian 32-bit words at data (4-byte aligned): a frame's check. */
uint32_t skin_crc32_words(const uint8_t *data, size_t nwords);

uint32_t skin_bit_reverse32(uint32_t x);

#ifdef SKIN_FW_CRC32_HW
/* Provided by the board: reset the unit to 0xFFFFFFFF, feed one word, read its register. */
void board_crc32_hw_reset(void);
void board_crc32_hw_feed(uint32_t word);
uint32_t board_crc32_hw_result(void);
#endif

#ifdef __cplusplus
}
#endif

#endif
