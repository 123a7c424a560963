/*
 * The USB link's descriptors (boards/nucleo_f446re/usb/usb_desc.c), as the host reads them at
 * enumeration: a CDC ACM device with 64-byte bulk endpoints and the unique ID as its serial.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "tusb.h"
#include "usb_desc.h"

static uint16_t le16(const uint8_t *p) { return (uint16_t)(p[0] | (p[1] << 8)); }

static void device_descriptor(void **state) {
  (void)state;
  const uint8_t *d = tud_descriptor_device_cb();
  assert_int_equal(d[0], 18);     /* bLength */
  assert_int_equal(d[1], 0x01);   /* DEVICE */
  assert_int_equal(le16(d + 2), 0x0200); /* USB 2.0 */
  /* Miscellaneous / common / IAD: the interface association groups the two CDC interfaces. */
  assert_int_equal(d[4], 0xEF);
  assert_int_equal(d[5], 0x02);
  assert_int_equal(d[6], 0x01);
  assert_int_equal(d[7], 64);     /* control endpoint */
  assert_int_equal(le16(d + 8), 0x1209);  /* pid.codes */
  assert_int_equal(le16(d + 10), 0x0001); /* its test PID */
  assert_int_equal(d[14], USB_STR_MANUFACTURER);
  assert_int_equal(d[15], USB_STR_PRODUCT);
  assert_int_equal(d[16], USB_STR_SERIAL);
  assert_int_equal(d[17], 1);     /* one configuration */
}

/* Walks the configuration descriptor: every sub-descriptor's length adds up to wTotalLength,
 * and the interfaces and endpoints are those of CDC ACM. */
static void configuration_descriptor(void **state) {
  (void)state;
  const uint8_t *c = tud_descriptor_configuration_cb(0);
  assert_int_equal(c[0], 9);
  assert_int_equal(c[1], 0x02);   /* CONFIGURATION */
  const uint16_t total = le16(c + 2);
  assert_int_equal(total, 9 + 8 + 9 + 5 + 5 + 4 + 5 + 7 + 9 + 7 + 7); /* 75 */
  assert_int_equal(c[4], 2);      /* two interfaces */
  assert_int_equal(c[5], 1);      /* bConfigurationValue */
  assert_int_equal(c[7] & 0xC0, 0xC0); /* self-powered (bit 7 always set) */

  int interfaces = 0, bulk_in = 0, bulk_out = 0, notify = 0, iad = 0;
  uint8_t klass[2] = {0, 0};
  uint16_t at = 0;
  while (at < total) {
    const uint8_t *d = c + at;
    assert_true(d[0] >= 2);
    assert_true(at + d[0] <= total);
    if (d[1] == 0x0B) { /* interface association */
      iad++;
      assert_int_equal(d[2], 0);  /* first interface */
      assert_int_equal(d[3], 2);  /* two of them */
      assert_int_equal(d[4], 0x02);
    } else if (d[1] == 0x04) { /* interface */
      assert_true(interfaces < 2);
      klass[interfaces] = d[5];
      assert_int_equal(d[2], interfaces); /* numbered 0, 1 */
      if (d[5] == 0x02) {
        assert_int_equal(d[6], 0x02); /* abstract control model */
        assert_int_equal(d[4], 1);    /* the notification endpoint */
      } else {
        assert_int_equal(d[4], 2);    /* bulk OUT and IN */
      }
      interfaces++;
    } else if (d[1] == 0x05) { /* endpoint */
      const uint8_t type = d[3] & 3u;
      const uint16_t size = le16(d + 4);
      if (type == 2 && (d[2] & 0x80)) {
        bulk_in++;
        assert_int_equal(d[2], USB_EP_IN);
        assert_int_equal(size, 64);
      } else if (type == 2) {
        bulk_out++;
        assert_int_equal(d[2], USB_EP_OUT);
        assert_int_equal(size, 64);
      } else {
        notify++;
        assert_int_equal(type, 3); /* interrupt */
        assert_int_equal(d[2], USB_EP_NOTIFY);
        assert_int_equal(size, 8);
      }
    }
    at = (uint16_t)(at + d[0]);
  }
  assert_int_equal(at, total);
  assert_int_equal(iad, 1);
  assert_int_equal(interfaces, 2);
  assert_int_equal(klass[0], 0x02); /* communication */
  assert_int_equal(klass[1], 0x0A); /* data */
  assert_int_equal(bulk_in, 1);
  assert_int_equal(bulk_out, 1);
  assert_int_equal(notify, 1);
}

/* A string descriptor back to ASCII; its length field must match. */
static void ascii(const uint16_t *s, char *out, size_t cap) {
  assert_int_equal(s[0] >> 8, 0x03); /* STRING */
  const size_t chars = ((s[0] & 0xFFu) - 2u) / 2u;
  assert_true(chars < cap);
  for (size_t i = 0; i < chars; i++) {
    assert_true(s[1 + i] < 0x80);
    out[i] = (char)s[1 + i];
  }
  out[chars] = '\0';
}

static void serial_from_unique_id(void **state) {
  (void)state;
  /* The same ID and hex as test_info's information frame (uid=...). */
  const uint8_t uid[12] = {0x00, 0x39, 0x00, 0x1e, 0x34, 0x38, 0x51, 0x0b, 0x34, 0x31, 0x39, 0x39};
  usb_desc_set_serial(uid);
  const uint16_t *s = tud_descriptor_string_cb(USB_STR_SERIAL, 0x0409);
  assert_non_null(s);
  assert_int_equal(s[0] & 0xFF, 2 + 2 * 24);
  char text[64];
  ascii(s, text, sizeof text);
  assert_string_equal(text, "0039001e3438510b34313939");

  const uint8_t ff[12] = {0xff, 0xfe, 0xa0, 0x0a, 0, 0, 0, 0, 0, 0, 0, 0x01};
  usb_desc_set_serial(ff);
  ascii(tud_descriptor_string_cb(USB_STR_SERIAL, 0x0409), text, sizeof text);
  assert_string_equal(text, "fffea00a0000000000000001");
}

static void other_strings(void **state) {
  (void)state;
  const uint16_t *lang = tud_descriptor_string_cb(USB_STR_LANGID, 0);
  assert_int_equal(lang[0], 0x0304);
  assert_int_equal(lang[1], 0x0409); /* English (US) */
  char text[64];
  ascii(tud_descriptor_string_cb(USB_STR_MANUFACTURER, 0x0409), text, sizeof text);
  assert_string_equal(text, "skin_driver");
  ascii(tud_descriptor_string_cb(USB_STR_PRODUCT, 0x0409), text, sizeof text);
  assert_string_equal(text, "skin nucleo-f446re");
  ascii(tud_descriptor_string_cb(USB_STR_CDC, 0x0409), text, sizeof text);
  assert_string_equal(text, "skin link");
  /* An index the device does not have: NULL, which TinyUSB answers with a stall. */
  assert_null(tud_descriptor_string_cb(USB_STR_COUNT, 0x0409));
  assert_null(tud_descriptor_string_cb(0xEE, 0x0409));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(device_descriptor),
      cmocka_unit_test(configuration_descriptor),
      cmocka_unit_test(serial_from_unique_id),
      cmocka_unit_test(other_strings),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
