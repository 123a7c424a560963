/* The checks against their published check values, zlib's definition and the F4 CRC unit path. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "skin_fw/crc.h"

static const uint8_t check_input[] = "123456789";

static void crc16_check_value(void **state) {
  (void)state;
  assert_int_equal(skin_crc16(check_input, 9), 0x29B1);
}

static void crc32_check_value(void **state) {
  (void)state;
  assert_int_equal(skin_crc32(check_input, 9), 0xCBF43926u);
}

static void crc_of_nothing_is_the_initial_value(void **state) {
  (void)state;
  assert_int_equal(skin_crc16(check_input, 0), 0xFFFF);
  assert_int_equal(skin_crc32(check_input, 0), 0u);
}

/* Bitwise ISO-HDLC, the definition the table must reproduce. */
static uint32_t crc32_bitwise(const uint8_t *p, size_t n) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; i++) {
    crc ^= p[i];
    for (int b = 0; b < 8; b++) {
      crc = (crc & 1u) ? (crc >> 1) ^ 0xEDB88320u : crc >> 1;
    }
  }
  return ~crc;
}

static void crc32_table_matches_definition(void **state) {
  (void)state;
  uint8_t data[1048];
  uint32_t x = 12345u;
  for (size_t i = 0; i < sizeof data; i++) {
    x = x * 1103515245u + 12345u;
    data[i] = (uint8_t)(x >> 16);
  }
  for (size_t n = 0; n <= sizeof data; n += 131) {
    assert_int_equal(skin_crc32(data, n), crc32_bitwise(data, n));
  }
}

static void crc32_words_is_crc32_of_the_bytes(void **state) {
  (void)state;
  _Alignas(4) uint8_t data[64];
  for (size_t i = 0; i < sizeof data; i++) {
    data[i] = (uint8_t)(i * 37u + 5u);
  }
  /* "12345678", whole words: zlib.crc32(b"12345678") */
  assert_int_equal(skin_crc32_words((const uint8_t *)"12345678", 2), 0x9AE0DAAFu);
  for (size_t w = 0; w <= sizeof data / 4; w++) {
    assert_int_equal(skin_crc32_words(data, w), crc32_bitwise(data, 4 * w));
  }
}

static void bit_reverse(void **state) {
  (void)state;
  assert_int_equal(skin_bit_reverse32(0x00000001u), 0x80000000u);
  assert_int_equal(skin_bit_reverse32(0x12345678u), 0x1E6A2C48u);
  assert_int_equal(skin_bit_reverse32(0xFFFF0000u), 0x0000FFFFu);
}

#ifdef SKIN_FW_CRC32_HW
/* The STM32F1/F4 CRC unit: CRC-32/MPEG-2 register, words shifted in MSB first, no reflection. */
static uint32_t unit;
static unsigned unit_resets;
void board_crc32_hw_reset(void) {
  unit = 0xFFFFFFFFu;
  unit_resets++;
}
void board_crc32_hw_feed(uint32_t word) {
  unit ^= word;
  for (int b = 0; b < 32; b++) {
    unit = (unit & 0x80000000u) ? (unit << 1) ^ 0x04C11DB7u : unit << 1;
  }
}
uint32_t board_crc32_hw_result(void) { return unit; }

static void hw_path_resets_the_unit_each_time(void **state) {
  (void)state;
  unit_resets = 0;
  (void)skin_crc32_words((const uint8_t *)"12345678", 2);
  (void)skin_crc32_words((const uint8_t *)"12345678", 2);
  assert_int_equal(unit_resets, 2);
}
#endif

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(crc16_check_value),
      cmocka_unit_test(crc32_check_value),
      cmocka_unit_test(crc_of_nothing_is_the_initial_value),
      cmocka_unit_test(crc32_table_matches_definition),
      cmocka_unit_test(crc32_words_is_crc32_of_the_bytes),
      cmocka_unit_test(bit_reverse),
#ifdef SKIN_FW_CRC32_HW
      cmocka_unit_test(hw_path_resets_the_unit_each_time),
#endif
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
