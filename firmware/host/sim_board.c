#include "skin_fw_host/sim_board.h"

#include <string.h>

#include "skin_fw/crc.h"
#include "skin_fw/frame.h"

int skin_sim_abi_version(void) { return SKIN_SIM_ABI_VERSION; }

uint32_t skin_sim_schedule_size(void) { return (uint32_t)sizeof(skin_info_schedule_t); }

uint32_t skin_sim_buffer_size(uint8_t rows, uint8_t cols) {
  return 4u * SKIN_FRAME_BUFFER_WORDS(rows, cols);
}

uint32_t skin_sim_frame(uint8_t *buf, uint32_t buf_size, uint8_t version, uint32_t seq,
                        uint64_t device_time_us, uint8_t rows, uint8_t cols,
                        const uint16_t *counts, uint16_t faults, const uint8_t *row_map) {
  if ((version != 1u && version != 2u) || !rows || !cols || ((uintptr_t)buf & 3u) ||
      buf_size < skin_sim_buffer_size(rows, cols)) {
    return 0u;
  }
  memcpy(skin_frame_counts(buf, version, rows), counts, 4u * (uint32_t)rows * cols);
  const skin_frame_meta_t meta = {version, rows, cols, seq, device_time_us, faults, row_map};
  return skin_frame_finish(buf, &meta);
}

uint32_t skin_sim_info(uint8_t *out, const char *name, const uint8_t uid[12], const char *fw,
                       uint8_t rows, uint8_t cols, uint32_t pitch_um, uint32_t rate_hz,
                       const char *extra) {
  skin_board_info_t board = {.name = name, .scan_rate_hz = rate_hz};
  memcpy(board.uid, uid, sizeof board.uid);
  const uint32_t len = skin_info_build(out, &board, NULL, fw, rows, cols, pitch_um);
  const size_t more = strlen(extra);
  if (!len || len - 6u + more > SKIN_INFO_MAX_TEXT) {
    return 0u;
  }
  /* The text grows by the extra fields: its length byte and its check follow. */
  const uint32_t body = len - 2u + (uint32_t)more;
  memcpy(out + len - 2u, extra, more);
  out[3] = (uint8_t)(body - 4u);
  const uint16_t crc = skin_crc16(out, body);
  out[body] = (uint8_t)crc;
  out[body + 1u] = (uint8_t)(crc >> 8);
  return body + 2u;
}
