/*
 * TinyUSB's settings for the Nucleo-F446RE's USB link: device only, full speed on the OTG FS
 * core (root-hub port 0), one CDC ACM interface, no RTOS. The host tests compile the descriptor
 * and link modules against the same file with CFG_TUSB_MCU set to OPT_MCU_NONE.
 */
#ifndef TUSB_CONFIG_H
#define TUSB_CONFIG_H

#ifndef CFG_TUSB_MCU
#define CFG_TUSB_MCU OPT_MCU_STM32F4
#endif
#define CFG_TUSB_OS OPT_OS_NONE
#define CFG_TUSB_DEBUG 0

#define CFG_TUSB_RHPORT0_MODE (OPT_MODE_DEVICE | OPT_MODE_FULL_SPEED)
#define CFG_TUD_ENABLED 1
#define CFG_TUD_MAX_SPEED OPT_MODE_FULL_SPEED
#define CFG_TUD_ENDPOINT0_SIZE 64

/* PA9 is USART1's TX, not VBUS: no VBUS sensing; the driver forces the B-session valid. */
#define CFG_TUD_VBUS_DETECT_HW 0
/* The F4's OTG FS has no internal DMA: the CPU fills the endpoint FIFOs (slave mode). */
#define CFG_TUD_DWC2_DMA_ENABLE 0
#define CFG_TUD_DWC2_SLAVE_ENABLE 1

#define CFG_TUD_CDC 1
/* Nothing is read from the host: one packet of room. */
#define CFG_TUD_CDC_RX_BUFSIZE 64
#define CFG_TUD_CDC_RX_EPSIZE 64
/*
 * Two kilobytes hold a whole 16 x 16 frame (1 048 bytes) and the start of the next; in slave
 * mode the bulk IN transfer reads this FIFO directly, so one transfer carries all of it and the
 * OTG interrupt feeds its packets while the CPU scans.
 */
#define CFG_TUD_CDC_TX_BUFSIZE 2048
#define CFG_TUD_CDC_TX_EPSIZE 64

#endif
