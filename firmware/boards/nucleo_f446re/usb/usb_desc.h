/*
 * The USB link's descriptors: a CDC ACM device (the host's /dev/ttyACM*), its strings, and the
 * serial number made from the MCU's 96-bit unique ID. TinyUSB asks for them through the
 * tud_descriptor_*_cb callbacks defined in usb_desc.c.
 */
#ifndef USB_DESC_H
#define USB_DESC_H

#include <stdint.h>

/*
 * pid.codes' test VID/PID (https://pid.codes/1209/0001/): for development only. Linux binds
 * cdc_acm by the interface class, so any pair works; a product shipped needs its own PID.
 */
#define USB_DESC_VID 0x1209u
#define USB_DESC_PID 0x0001u
#define USB_DESC_BCD_DEVICE 0x0100u

/* String indices. */
enum {
  USB_STR_LANGID = 0,
  USB_STR_MANUFACTURER = 1,
  USB_STR_PRODUCT = 2,
  USB_STR_SERIAL = 3,
  USB_STR_CDC = 4,
  USB_STR_COUNT = 5,
};

/* Endpoints: CDC notification (interrupt IN), data OUT and data IN (bulk, 64 bytes). */
#define USB_EP_NOTIFY 0x81u
#define USB_EP_OUT 0x02u
#define USB_EP_IN 0x82u
#define USB_EP_NOTIFY_SIZE 8u
#define USB_EP_BULK_SIZE 64u

/*
 * The serial number string: the 12 bytes of the unique ID in hex, in memory order, as the
 * board-information frame's `uid=` gives it, so /dev/serial/by-id/ names the same board
 * skin_info reports. Call before the host can ask (before tusb_init).
 */
void usb_desc_set_serial(const uint8_t uid[12]);

#endif
