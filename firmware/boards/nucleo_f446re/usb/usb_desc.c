/*
 * Descriptors of the USB link (usb_desc.h): one configuration with the two CDC ACM interfaces
 * (communication with its notification endpoint, data with bulk OUT and IN), bound together by
 * an interface association, as TinyUSB's CDC class expects.
 */
#include "usb_desc.h"

#include "tusb.h"

static const tusb_desc_device_t device = {
    .bLength = sizeof(tusb_desc_device_t),
    .bDescriptorType = TUSB_DESC_DEVICE,
    .bcdUSB = 0x0200,
    /* Miscellaneous / common class / IAD: the interface association names the function. */
    .bDeviceClass = TUSB_CLASS_MISC,
    .bDeviceSubClass = MISC_SUBCLASS_COMMON,
    .bDeviceProtocol = MISC_PROTOCOL_IAD,
    .bMaxPacketSize0 = CFG_TUD_ENDPOINT0_SIZE,
    .idVendor = USB_DESC_VID,
    .idProduct = USB_DESC_PID,
    .bcdDevice = USB_DESC_BCD_DEVICE,
    .iManufacturer = USB_STR_MANUFACTURER,
    .iProduct = USB_STR_PRODUCT,
    .iSerialNumber = USB_STR_SERIAL,
    .bNumConfigurations = 1,
};

#define CONFIG_TOTAL_LEN (TUD_CONFIG_DESC_LEN + TUD_CDC_DESC_LEN)

/* Self-powered: the Nucleo runs from the ST-LINK's USB; the expander's VBUS feeds nothing. */
static const uint8_t configuration[] = {
    TUD_CONFIG_DESCRIPTOR(1, 2, 0, CONFIG_TOTAL_LEN, TUSB_DESC_CONFIG_ATT_SELF_POWERED, 100),
    TUD_CDC_DESCRIPTOR(0, USB_STR_CDC, USB_EP_NOTIFY, USB_EP_NOTIFY_SIZE, USB_EP_OUT, USB_EP_IN,
                       USB_EP_BULK_SIZE),
};
_Static_assert(sizeof configuration == CONFIG_TOTAL_LEN, "configuration descriptor length");

static const char *const strings[USB_STR_COUNT] = {
    [USB_STR_MANUFACTURER] = "skin_driver",
    [USB_STR_PRODUCT] = "skin nucleo-f446re",
    [USB_STR_CDC] = "skin link",
};

static char serial[2 * 12 + 1] = "000000000000000000000000";

/* The longest string above, as UTF-16 after the 2-byte header. */
#define STRING_MAX_CHARS 32u
static uint16_t string_out[1 + STRING_MAX_CHARS];

void usb_desc_set_serial(const uint8_t uid[12]) {
  static const char hex[] = "0123456789abcdef";
  for (uint32_t i = 0; i < 12u; i++) {
    serial[2u * i] = hex[uid[i] >> 4];
    serial[2u * i + 1u] = hex[uid[i] & 15u];
  }
  serial[24] = '\0';
}

const uint8_t *tud_descriptor_device_cb(void) { return (const uint8_t *)&device; }

const uint8_t *tud_descriptor_configuration_cb(uint8_t index) {
  (void)index; /* one configuration */
  return configuration;
}

const uint16_t *tud_descriptor_string_cb(uint8_t index, uint16_t langid) {
  (void)langid; /* English (US) only */
  uint32_t chars;
  if (index == USB_STR_LANGID) {
    string_out[1] = 0x0409u;
    chars = 1u;
  } else {
    const char *s = index == USB_STR_SERIAL ? serial : index < USB_STR_COUNT ? strings[index] : 0;
    if (s == 0) {
      return 0; /* TinyUSB stalls the request */
    }
    for (chars = 0; s[chars] != '\0' && chars < STRING_MAX_CHARS; chars++) {
      string_out[1u + chars] = (uint8_t)s[chars]; /* ASCII: the low byte of UTF-16 */
    }
  }
  string_out[0] = (uint16_t)((TUSB_DESC_STRING << 8) | (2u * chars + 2u));
  return string_out;
}
