/* A grid beyond the protocol's default host limit: the core must refuse to build with it. */
#ifndef SKIN_FW_CONFIG_H
#define SKIN_FW_CONFIG_H

#define SKIN_FW_ROWS 129
#define SKIN_FW_COLS 16
#define SKIN_FW_PITCH_UM 5000
#define SKIN_FW_SETTLE_US 0
#define SKIN_FW_VERSION "0.0.0"

#endif
