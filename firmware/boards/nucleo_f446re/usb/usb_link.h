/*
 * The board link over USB (the board interface's board_link_send / board_link_idle, in
 * usb_link.c, with no register in it so the host tests can run it against a fake CDC class).
 */
#ifndef USB_LINK_H
#define USB_LINK_H

#include <stdint.h>

/* Give the USB stack the CPU (tud_task) and move what waits into the CDC FIFO. */
void usb_link_poll(void);

/* Forget any frame in progress (after init, or when the host closes the port). */
void usb_link_reset(void);

/* Frames or parts of frames thrown away because no host had the port open. */
extern volatile uint32_t usb_link_discarded;

#endif
