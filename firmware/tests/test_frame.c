/* The frame's bytes against frames Python's wire.encode_frame produced, in both versions. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "skin_fw/frame.h"

static const uint16_t counts[] = {1, 4095, 256, 0x0ABC};

/* encode_frame(0x01020304, 0x1122334455667788, [[1, 4095]], [[256, 0x0abc]]) */
static const uint8_t expected_v1[] = {
    0xA5, 0x5A, 0x01, 0x00, 0x04, 0x03, 0x02, 0x01, 0x88, 0x77, 0x66,
    0x55, 0x44, 0x33, 0x22, 0x11, 0x01, 0x02, 0x6C, 0xCA, 0x01, 0x00,
    0xFF, 0x0F, 0x00, 0x01, 0xBC, 0x0A, 0x57, 0x54, 0x12, 0x16};

/* The same with version=2 */
static const uint8_t expected_v2[] = {
    0xA5, 0x5A, 0x02, 0x00, 0x04, 0x03, 0x02, 0x01, 0x88, 0x77, 0x66,
    0x55, 0x44, 0x33, 0x22, 0x11, 0x01, 0x02, 0x21, 0x22, 0x00, 0x00,
    0x01, 0x01, 0x01, 0xF0, 0xFF, 0x00, 0xC1, 0xAB, 0x00, 0x00, 0xDA,
    0x64, 0x92, 0x5D};

/* The same with version=2, faults=0x11, row_valid=[[True], [False]] (the bottom row failed) */
static const uint8_t expected_v2_flagged[] = {
    0xA5, 0x5A, 0x02, 0x03, 0x04, 0x03, 0x02, 0x01, 0x88, 0x77, 0x66,
    0x55, 0x44, 0x33, 0x22, 0x11, 0x01, 0x02, 0x04, 0xC1, 0x11, 0x00,
    0x01, 0x00, 0x01, 0xF0, 0xFF, 0x00, 0xC1, 0xAB, 0x00, 0x00, 0x54,
    0x3F, 0xC8, 0x22};

static uint32_t finish(uint32_t *buf, size_t words, uint8_t version, uint16_t faults,
                       const uint8_t *row_map) {
  memset(buf, 0xEE, 4 * words);
  uint8_t *frame = (uint8_t *)buf;
  memcpy(skin_frame_counts(frame, version, 1), counts, sizeof counts);
  const skin_frame_meta_t meta = {version, 1, 2, 0x01020304u, 0x1122334455667788ull, faults,
                                  row_map};
  return skin_frame_finish(frame, &meta);
}

/* The frame finished from `counts` with these fields is `expected`, byte for byte. */
static void assert_finished(uint8_t version, uint16_t faults, const uint8_t *row_map,
                            const uint8_t *expected, size_t size) {
  uint32_t buf[SKIN_FRAME_BUFFER_WORDS(1, 2)];
  const uint32_t len = finish(buf, SKIN_FRAME_BUFFER_WORDS(1, 2), version, faults, row_map);
  assert_int_equal(len, size);
  assert_memory_equal(buf, expected, size);
}

static void frame_bytes_are_the_protocols_v1(void **state) {
  (void)state;
  /* Version 1 has no fault bits and no row map: they are not sent. */
  const uint8_t map[] = {0x00, 0x00};
  assert_finished(1, 0x11, map, expected_v1, sizeof expected_v1);
}

static void frame_bytes_are_the_protocols_v2(void **state) {
  (void)state;
  assert_finished(2, 0, NULL, expected_v2, sizeof expected_v2);
}

static void v2_marks_an_invalid_row_and_the_fault_bits(void **state) {
  (void)state;
  /* Spare bits set in the map given are not sent; the row-failed bit follows the map. */
  const uint8_t map[] = {0xFF, 0xFE};
  assert_finished(2, 0x10, map, expected_v2_flagged, sizeof expected_v2_flagged);
}

static void v2_reports_a_sample_out_of_range_as_an_adc_fault(void **state) {
  (void)state;
  uint32_t buf[SKIN_FRAME_BUFFER_WORDS(1, 2)];
  memset(buf, 0, sizeof buf);
  uint8_t *frame = (uint8_t *)buf;
  const uint16_t bad[] = {1, 0x1FFF, 256, 0x0ABC};
  memcpy(skin_frame_counts(frame, 2, 1), bad, sizeof bad);
  const skin_frame_meta_t meta = {2, 1, 2, 0u, 0u, 0u, NULL};
  (void)skin_frame_finish(frame, &meta);
  assert_int_equal(frame[3], SKIN_FLAG_FAULT);
  assert_int_equal(frame[20], SKIN_FAULT_ADC);
  /* Masked to 12 bits when packed: the second count reads 0xFFF. */
  assert_int_equal(frame[25], 0xF0);
  assert_int_equal(frame[26], 0xFF);
}

static void frame_sizes(void **state) {
  (void)state;
  assert_int_equal(SKIN_FRAME_V1_SIZE(16, 16), 1048);
  assert_int_equal(SKIN_FRAME_V1_SIZE(128, 128), 65560);
  assert_int_equal(SKIN_FRAME_V1_SIZE(1, 1), 28);
  assert_int_equal(SKIN_FRAME_V2_SIZE(16, 16), 800);
  assert_int_equal(SKIN_FRAME_V2_SIZE(128, 128), 49212);
  assert_int_equal(SKIN_FRAME_V2_SIZE(1, 1), 32);
  assert_int_equal(skin_frame_size(1, 16, 16), 1048);
  assert_int_equal(skin_frame_size(2, 16, 16), 800);
  /* Room for the row slack past the samples, in whole words, in either version. */
  assert_true(SKIN_FRAME_BUFFER_WORDS(1, 1) * 4 >= 20 + 4 + 2 * SKIN_FW_ROW_SLACK);
  assert_true(SKIN_FRAME_BUFFER_WORDS(16, 16) * 4 >=
              SKIN_FRAME_V2_SAMPLES_AT(16) + 4 * 256 + 2 * SKIN_FW_ROW_SLACK);
}

static void samples_start_on_a_word_at_or_after_the_packed_counts(void **state) {
  (void)state;
  uint32_t buf[SKIN_FRAME_BUFFER_WORDS(1, 1)];
  assert_ptr_equal(skin_frame_counts((uint8_t *)buf, 1, 1), (uint8_t *)buf + 20);
  assert_ptr_equal(skin_frame_counts((uint8_t *)buf, 2, 1), (uint8_t *)buf + 24);
  assert_int_equal(SKIN_FRAME_V2_SAMPLES_AT(16), 28);
  assert_int_equal(SKIN_FRAME_V2_SAMPLES_AT(9), 28);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(frame_bytes_are_the_protocols_v1),
      cmocka_unit_test(frame_bytes_are_the_protocols_v2),
      cmocka_unit_test(v2_marks_an_invalid_row_and_the_fault_bits),
      cmocka_unit_test(v2_reports_a_sample_out_of_range_as_an_adc_fault),
      cmocka_unit_test(frame_sizes),
      cmocka_unit_test(samples_start_on_a_word_at_or_after_the_packed_counts),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
