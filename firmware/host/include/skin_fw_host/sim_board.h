/*
 * The firmware core built for the host: what the simulated board (skin_driver/core/sim) frames
 * through, so that a simulated frame is the firmware's byte for byte. The schedule of the
 * information frame is skin_fw/info.h's skin_info_schedule_*, exported as they are.
 *
 * The library is libskin_fw_host.so.<SKIN_SIM_ABI_VERSION>; its binding (core/sim/firmware.py)
 * checks the version and the schedule's size when it loads it.
 */
#ifndef SKIN_FW_HOST_SIM_BOARD_H
#define SKIN_FW_HOST_SIM_BOARD_H

#include <stdint.h>

#include "skin_fw/info.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SKIN_SIM_ABI_VERSION 1

int skin_sim_abi_version(void);
uint32_t skin_sim_schedule_size(void);

/* Bytes of the 4-byte-aligned buffer skin_sim_frame builds a frame of this grid in. */
uint32_t skin_sim_buffer_size(uint8_t rows, uint8_t cols);

/*
 * Build the data frame of protocol `version` (1 or 2) at the start of buf, as the board does
 * (its samples in place, then skin_frame_finish); return its size, or 0 when the version is
 * neither, the grid empty, or buf misaligned or shorter than skin_sim_buffer_size.
 * counts: the top layer's rows*cols uint16 samples, row-major, then the bottom layer's.
 * faults, row_map: as skin_frame_meta_t has them (version 2 only; row_map NULL: all sampled).
 */
uint32_t skin_sim_frame(uint8_t *buf, uint32_t buf_size, uint8_t version, uint32_t seq,
                        uint64_t device_time_us, uint8_t rows, uint8_t cols,
                        const uint16_t *counts, uint16_t faults, const uint8_t *row_map);

/*
 * Build the board information frame of these fields into out (SKIN_INFO_MAX_SIZE bytes) with
 * skin_info_build, then the fields of `extra` (";key=value..." or "": a simulated board's health,
 * which has no status or counters of its own); return its size, or 0 when it does not fit.
 */
uint32_t skin_sim_info(uint8_t *out, const char *name, const uint8_t uid[12], const char *fw,
                       uint8_t rows, uint8_t cols, uint32_t pitch_um, uint32_t rate_hz,
                       const char *extra);

#ifdef __cplusplus
}
#endif

#endif
