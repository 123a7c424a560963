/* The grid of the host tests of skin_fw_run (test_run.c): small and not square. */
#ifndef SKIN_FW_CONFIG_H
#define SKIN_FW_CONFIG_H

#define SKIN_FW_ROWS 3
#define SKIN_FW_COLS 5
#define SKIN_FW_PITCH_UM 4500
#define SKIN_FW_SETTLE_US 7
#define SKIN_FW_VERSION "1.2.3"

#endif
