/*
 * The firmware's main loop.
 *
 * A board provides the functions of skin_fw/board.h and a header skin_fw_config.h on the include
 * path with:
 *   SKIN_FW_ROWS       rows of each layer, 1..128
 *   SKIN_FW_COLS       columns of each layer, 1..128
 *   SKIN_FW_PITCH_UM   taxel pitch in micrometres (integer, > 0)
 *   SKIN_FW_SETTLE_US  microseconds a driven row settles before it is sampled
 *   SKIN_FW_VERSION    firmware version string "major.minor.patch"
 * Optional: SKIN_FW_INFO_PERIOD_US (default 1 000 000), how often the information frame repeats.
 *           SKIN_FW_PROTOCOL (default 2), the wire protocol version of the frames, 1 or 2
 *           (docs/protocol.md; cmake -DSKIN_FW_PROTOCOL=1 for every board).
 * Its main() calls skin_fw_run().
 */
#ifndef SKIN_FW_FW_H
#define SKIN_FW_FW_H

#ifdef __cplusplus
extern "C" {
#endif

/* Initialise the board, send the information frame, then scan at every scan tick. */
void skin_fw_run(void) __attribute__((noreturn));

/* skin_fw_run() in two parts, for tests: the start, and one scan tick of the loop. */
void skin_fw_start(void);
void skin_fw_step(void);

/*
 * The board's link has a new reader (the host opened the USB port): the information frame goes
 * ahead of the next scan's frame (skin_info_due_now). Called from the main loop, between scans.
 */
void skin_fw_info_now(void);

#ifdef __cplusplus
}
#endif

#endif
