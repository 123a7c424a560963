#include "skin_fw/frame.h"

#include "skin_fw/crc.h"

/* Byte by byte, so the layout is the wire's whatever the compiler does with a packed struct. */
static void put_le(uint8_t *p, uint64_t value, int bytes) {
  for (int i = 0; i < bytes; i++) {
    p[i] = (uint8_t)(value >> (8 * i));
  }
}

uint32_t skin_frame_finish(uint8_t *frame, uint8_t rows, uint8_t cols, uint32_t seq,
                           uint64_t device_time_us) {
  const uint32_t size = SKIN_FRAME_SIZE(rows, cols);
  frame[0] = 0xA5u;
  frame[1] = 0x5Au;
  frame[2] = 1u; /* protocol version */
  frame[3] = 0u; /* flags */
  put_le(frame + 4, seq, 4);
  put_le(frame + 8, device_time_us, 8);
  frame[16] = rows;
  frame[17] = cols;
  put_le(frame + 18, skin_crc16(frame, 18u), 2);
  /* 20 + 4n bytes: whole words from the aligned start, as a CRC unit wants them. */
  put_le(frame + size - 4u, skin_crc32_words(frame, (size - 4u) / 4u), 4);
  return size;
}
