/*
 * The board link over USB (the board interface's board_link_send / board_link_idle, in
 * usb_link.c, with no register in it so the host tests can run it against a fake CDC class).
 */
#ifndef USB_LINK_H
#define USB_LINK_H

#include <stdint.h>

/*
 * How long a frame may wait with the port open and not one byte taken before it is discarded:
 * far longer than the 2 kB FIFO takes to drain at any rate the host reads (a few ms).
 */
#define USB_LINK_STALL_US 100000u

/*
 * While the core waits for the scan tick: give the USB stack the CPU (tud_task), move what waits
 * into the CDC FIFO, and open a port the host has opened since (DTR) for the next frame, the
 * information frame (skin_fw_info_now). The waits for the link run the stack but open nothing:
 * a frame the core has already decided on is not the one that names the board.
 */
void usb_link_poll(void);

/* Forget any frame in progress (after init, or when the host closes the port). */
void usb_link_reset(void);

/* Frames or parts of frames thrown away because no host had the port open. */
extern volatile uint32_t usb_link_discarded;

#endif
