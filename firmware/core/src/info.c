#include "skin_fw/info.h"

#include "skin_fw/crc.h"
#include "skin_fw/fault.h"
#include "skin_fw/frame.h"

/* The frames-with-a-failed-row counter of the other protocol version: always 0, not sent. */
#define OTHER_VERSIONS_COUNTER \
  (SKIN_FW_PROTOCOL == 1 ? SKIN_FAULT_FRAME_FLAGGED : SKIN_FAULT_FRAME_DROPPED)

typedef struct {
  uint8_t *text;
  uint32_t len;
  int overflow;
} text_t;

static void put_char(text_t *t, char c) {
  if (t->len >= SKIN_INFO_MAX_TEXT) {
    t->overflow = 1;
    return;
  }
  t->text[t->len++] = (uint8_t)c;
}

static void put_str(text_t *t, const char *s) {
  for (; *s; s++) {
    put_char(t, *s);
  }
}

/* The text must stay parseable as key=value;...: anything that would break it becomes '_'. */
static void put_field_value(text_t *t, const char *s) {
  for (; *s; s++) {
    const char c = *s;
    put_char(t, (c < 0x20 || c > 0x7E || c == ';' || c == '=') ? '_' : c);
  }
}

static void put_uint(text_t *t, uint32_t v) {
  char digits[10];
  int n = 0;
  do {
    digits[n++] = (char)('0' + v % 10u);
    v /= 10u;
  } while (v);
  while (n) {
    put_char(t, digits[--n]);
  }
}

/* ";key=value" whole, or nothing when it does not fit (the text stays parseable). */
static void put_optional(text_t *t, const char *key, const char *value, uint32_t number) {
  const uint32_t mark = t->len;
  put_char(t, ';');
  put_str(t, key);
  put_char(t, '=');
  if (value) {
    put_field_value(t, value);
  } else {
    put_uint(t, number);
  }
  if (t->overflow) {
    t->len = mark;
    t->overflow = 0;
  }
}

static void put_status(text_t *t, const skin_board_status_t *status) {
  if (status->reset_cause) {
    put_optional(t, "reset", status->reset_cause, 0u);
  }
  if (status->fault) {
    put_optional(t, "fault", status->fault, 0u);
  }
  if (status->clock) {
    put_optional(t, "clock", status->clock, 0u);
  }
  for (unsigned f = 0; f < SKIN_FAULTS; f++) {
    if (f != OTHER_VERSIONS_COUNTER) {
      put_optional(t, skin_fault_key((skin_fault_t)f), NULL, skin_fault_get((skin_fault_t)f));
    }
  }
}

uint32_t skin_info_build(uint8_t out[SKIN_INFO_MAX_SIZE], const skin_board_info_t *board,
                         const skin_board_status_t *status, const char *fw_version, uint8_t rows,
                         uint8_t cols, uint32_t pitch_um) {
  static const char hex[] = "0123456789abcdef";
  text_t t = {out + 4, 0u, 0};
  put_str(&t, "board=");
  put_field_value(&t, board->name ? board->name : "");
  put_str(&t, ";uid=");
  for (int i = 0; i < 12; i++) {
    put_char(&t, hex[board->uid[i] >> 4]);
    put_char(&t, hex[board->uid[i] & 0x0Fu]);
  }
  put_str(&t, ";fw=");
  put_field_value(&t, fw_version);
  put_str(&t, ";grid=");
  put_uint(&t, rows);
  put_char(&t, 'x');
  put_uint(&t, cols);
  put_str(&t, ";pitch_um=");
  put_uint(&t, pitch_um);
  put_str(&t, ";rate_hz=");
  put_uint(&t, board->scan_rate_hz);
  if (t.overflow) {
    return 0u;
  }
  if (status) {
    put_status(&t, status);
  }
  out[0] = 0xA5u;
  out[1] = 0x69u;
  out[2] = SKIN_INFO_VERSION;
  out[3] = (uint8_t)t.len;
  const uint32_t body = 4u + t.len;
  const uint16_t crc = skin_crc16(out, body);
  out[body] = (uint8_t)crc;
  out[body + 1u] = (uint8_t)(crc >> 8);
  return body + 2u;
}

void skin_info_schedule_init(skin_info_schedule_t *s, uint64_t period_us) {
  *s = (skin_info_schedule_t){.due_us = 0u, .period_us = period_us, .started = 0u};
}

bool skin_info_due(const skin_info_schedule_t *s, uint64_t now_us) {
  return !s->started || now_us >= s->due_us;
}

void skin_info_sent(skin_info_schedule_t *s, uint64_t now_us) {
  if (!s->started) {
    s->due_us = now_us;
    s->started = 1u;
  }
  s->due_us += s->period_us;
  if (s->due_us <= now_us) {
    s->due_us = now_us + s->period_us;
  }
}

void skin_info_due_now(skin_info_schedule_t *s) { s->started = 0u; }
