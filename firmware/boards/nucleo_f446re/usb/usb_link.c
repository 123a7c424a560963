/*
 * The link over USB: frames go into TinyUSB's CDC transmit FIFO and leave by bulk IN.
 *
 * Who runs when: the OTG interrupt moves packets between the FIFO and the endpoint while the
 * CPU scans; tud_task() (the stack's thread part: requests, transfer completions, starting the
 * next transfer) runs here, whenever the core waits, for the link (board_link_idle) or for the
 * scan tick (nucleo_link_poll). A frame is released to the core once all of it is in the FIFO.
 *
 * With no host holding the port open (DTR low, or not enumerated) frames are discarded, not
 * queued: the scans keep their rate. The port the host opens (DTR rising, in whichever wait
 * tud_task ran) opens for frames at the next wait for the scan tick, between two frames, with
 * the information frame due ahead of the next one (skin_fw_info_now): the host's first byte
 * starts the frame that names the board. A host that holds the port open but has stopped reading
 * does not stop the board either: after USB_LINK_STALL_US without a byte taken, the rest of the
 * frame is discarded (the driver sees a torn frame and resynchronises on the next).
 */
#include "usb_link.h"

#include "skin_fw/board.h"
#include "skin_fw/fw.h"
#include "tusb.h"

volatile uint32_t usb_link_discarded;
static const uint8_t *pending;
static uint32_t left;
static uint32_t progress_us; /* when the FIFO last took a byte of the pending frame */
static bool host_open;       /* DTR as the host last set it */
static bool port_open;       /* frames go to the host: DTR high since the last scan tick */

void usb_link_reset(void) {
  pending = 0;
  left = 0;
}

static void pump(void) {
  if (left == 0u) {
    return;
  }
  if (!port_open || !tud_cdc_connected()) {
    usb_link_discarded++;
    usb_link_reset();
    return;
  }
  const uint32_t n = tud_cdc_write(pending, left);
  pending += n;
  left -= n;
  tud_cdc_write_flush();
  const uint32_t now = board_time_us32();
  if (n != 0u) {
    progress_us = now;
  } else if ((uint32_t)(now - progress_us) > USB_LINK_STALL_US) {
    usb_link_discarded++;
    usb_link_reset();
  }
}

static void service(void) {
  tud_task();
  pump();
}

void usb_link_poll(void) {
  service();
  if (host_open && !port_open) {
    /* Between two frames (the core waits for the scan tick): nothing of a frame is pending. */
    port_open = true;
    skin_fw_info_now();
  }
}

void board_link_send(const uint8_t *buf, uint32_t len) {
  pending = buf;
  left = len;
  progress_us = board_time_us32();
  pump();
}

bool board_link_idle(void) {
  service();
  return left == 0u;
}

bool board_link_abort(void) {
  /* The core's bound ran out: the host holds the port open but takes nothing. The rest of the
   * frame goes (counted), as after USB_LINK_STALL_US. Not a stall of the board's own (the stack
   * runs, nothing to reset): a host that stops reading must not reset the board through the
   * watchdog, so this says every byte was dealt with. */
  if (left != 0u) {
    usb_link_discarded++;
  }
  usb_link_reset();
  return false;
}

static void new_session(void) {
  /* What is left in the FIFO belongs to a session that has ended: the next one starts clean, on
   * a frame boundary (the rest of a frame being written goes too). */
  tud_cdc_write_clear();
  if (left != 0u) {
    usb_link_discarded++;
  }
  usb_link_reset();
}

/* The host opened or closed the port: DTR changed. RTS alone changing is not a new session
 * (a host may set the two lines in separate requests). */
void tud_cdc_line_state_cb(uint8_t itf, bool dtr, bool rts) {
  (void)itf;
  (void)rts;
  if (dtr != host_open) {
    host_open = dtr;
    port_open = false; /* closed now; opened at the next scan tick if DTR is high */
    new_session();
  }
}

/* Configured (after a bus reset, the line state is cleared): the port is closed until DTR. */
void tud_mount_cb(void) {
  host_open = false;
  port_open = false;
  new_session();
}
