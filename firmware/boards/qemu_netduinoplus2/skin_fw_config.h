/* The emulated board's skin: the seed's 16 x 16 patch at 5 mm (the bundled scenes' model). */
#ifndef SKIN_FW_CONFIG_H
#define SKIN_FW_CONFIG_H

#define SKIN_FW_ROWS 16
#define SKIN_FW_COLS 16
#define SKIN_FW_PITCH_UM 5000
#define SKIN_FW_SETTLE_US 2
#define SKIN_FW_VERSION "0.1.0"

#endif
