#include "skin_fw/frame.h"

#include "skin_fw/crc.h"

/* Byte by byte, so the layout is the wire's whatever the compiler does with a packed struct. */
static void put_le(uint8_t *p, uint64_t value, int bytes) {
  for (int i = 0; i < bytes; i++) {
    p[i] = (uint8_t)(value >> (8 * i));
  }
}

uint32_t skin_frame_size(uint8_t version, uint8_t rows, uint8_t cols) {
  return version == 1u ? SKIN_FRAME_V1_SIZE(rows, cols) : SKIN_FRAME_V2_SIZE(rows, cols);
}

/*
 * Pack the 2n samples at frame + SKIN_FRAME_V2_SAMPLES_AT into 3n bytes at the counts' offset,
 * forward and in place: pair k is read (4 bytes at S + 4k) before its 3 bytes are written (at
 * C + 3k with C <= S), which end at or before the next pair's. Return the samples' OR, whose
 * bits above 11 say that one was out of range.
 */
static uint16_t pack_counts(uint8_t *frame, uint8_t rows, uint32_t pairs) {
  const uint16_t *in = (const uint16_t *)(const void *)(frame + SKIN_FRAME_V2_SAMPLES_AT(rows));
  uint8_t *out = frame + SKIN_FRAME_V2_COUNTS_AT(rows);
  uint16_t all = 0u;
  for (uint32_t k = 0; k < pairs; k++) {
    const uint16_t a = in[2u * k];
    const uint16_t b = in[2u * k + 1u];
    all |= (uint16_t)(a | b);
    out[3u * k] = (uint8_t)a;
    out[3u * k + 1u] = (uint8_t)(((a >> 8) & 0x0Fu) | ((b & 0x0Fu) << 4));
    out[3u * k + 2u] = (uint8_t)(b >> 4);
  }
  return all;
}

/* Write the fault bits, the row map, the packed counts and the padding; return the flags. */
static uint8_t finish_body(uint8_t *frame, const skin_frame_meta_t *m, uint32_t size) {
  const uint32_t map = SKIN_ROW_MAP_BYTES(m->rows);
  uint16_t faults = m->faults;
  uint8_t flags = 0u;
  uint8_t *row_map = frame + 22u;
  for (uint32_t layer = 0; layer < 2u; layer++) {
    for (uint32_t i = 0; i < map; i++) {
      /* All rows sampled: ones up to the last row, zeros in the spare bits. */
      const uint32_t left = m->rows - 8u * i;
      const uint8_t full = (uint8_t)(left >= 8u ? 0xFFu : (1u << left) - 1u);
      const uint8_t got = m->row_map ? (uint8_t)(m->row_map[layer * map + i] & full) : full;
      row_map[layer * map + i] = got;
      if (got != full) {
        flags |= SKIN_FLAG_ROWS_INVALID;
      }
    }
  }
  const uint32_t pairs = (uint32_t)m->rows * m->cols;
  if (pack_counts(frame, m->rows, pairs) > 0x0FFFu) {
    faults |= SKIN_FAULT_ADC;
  }
  if (flags & SKIN_FLAG_ROWS_INVALID) {
    faults |= SKIN_FAULT_ROW_FAILED;
  }
  if (faults) {
    flags |= SKIN_FLAG_FAULT;
  }
  put_le(frame + 20, faults, 2);
  for (uint32_t i = SKIN_FRAME_V2_BODY(m->rows, m->cols); i < size - 4u; i++) {
    frame[i] = 0u;
  }
  return flags;
}

uint32_t skin_frame_finish(uint8_t *frame, const skin_frame_meta_t *m) {
  const uint32_t size = skin_frame_size(m->version, m->rows, m->cols);
  uint8_t flags = 0u;
  if (m->version != 1u) {
    flags = finish_body(frame, m, size);
  }
  frame[0] = 0xA5u;
  frame[1] = 0x5Au;
  frame[2] = m->version == 1u ? 1u : 2u;
  frame[3] = flags;
  put_le(frame + 4, m->seq, 4);
  put_le(frame + 8, m->device_time_us, 8);
  frame[16] = m->rows;
  frame[17] = m->cols;
  put_le(frame + 18, skin_crc16(frame, 18u), 2);
  /* Whole words from the aligned start in both versions, as a CRC unit wants them. */
  put_le(frame + size - 4u, skin_crc32_words(frame, (size - 4u) / 4u), 4);
  return size;
}
