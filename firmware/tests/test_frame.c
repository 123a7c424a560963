/* The frame's bytes against a frame Python's wire.encode_frame produced. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "skin_fw/frame.h"

/* encode_frame(0x01020304, 0x1122334455667788, [[1, 4095]], [[256, 0x0abc]]) */
static const uint8_t expected[] = {
    0xA5, 0x5A, 0x01, 0x00, 0x04, 0x03, 0x02, 0x01, 0x88, 0x77, 0x66,
    0x55, 0x44, 0x33, 0x22, 0x11, 0x01, 0x02, 0x6C, 0xCA, 0x01, 0x00,
    0xFF, 0x0F, 0x00, 0x01, 0xBC, 0x0A, 0x57, 0x54, 0x12, 0x16};

static void frame_bytes_are_the_protocols(void **state) {
  (void)state;
  uint32_t buf[SKIN_FRAME_BUFFER_WORDS(1, 2)];
  memset(buf, 0xEE, sizeof buf);
  uint8_t *frame = (uint8_t *)buf;
  const uint16_t counts[] = {1, 4095, 256, 0x0ABC};
  memcpy(skin_frame_counts(frame), counts, sizeof counts);
  const uint32_t len = skin_frame_finish(frame, 1, 2, 0x01020304u, 0x1122334455667788ull);
  assert_int_equal(len, sizeof expected);
  assert_memory_equal(frame, expected, sizeof expected);
}

static void frame_size_is_24_plus_4n(void **state) {
  (void)state;
  assert_int_equal(SKIN_FRAME_SIZE(16, 16), 1048);
  assert_int_equal(SKIN_FRAME_SIZE(128, 128), 65560);
  assert_int_equal(SKIN_FRAME_SIZE(1, 1), 28);
  /* Room for the row slack past the payload, in whole words. */
  assert_true(SKIN_FRAME_BUFFER_WORDS(1, 1) * 4 >= 20 + 4 + 2 * SKIN_FW_ROW_SLACK);
}

static void payload_starts_at_offset_20(void **state) {
  (void)state;
  uint32_t buf[SKIN_FRAME_BUFFER_WORDS(1, 1)];
  assert_ptr_equal(skin_frame_counts((uint8_t *)buf), (uint8_t *)buf + 20);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(frame_bytes_are_the_protocols),
      cmocka_unit_test(frame_size_is_24_plus_4n),
      cmocka_unit_test(payload_starts_at_offset_20),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
