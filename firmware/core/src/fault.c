#include "skin_fw/fault.h"

static volatile uint32_t counts[SKIN_FAULTS];

static const char *const keys[SKIN_FAULTS] = {
    [SKIN_FAULT_FRAME_DROPPED] = "drop",    [SKIN_FAULT_FRAME_FLAGGED] = "flagged",
    [SKIN_FAULT_ADC_OVERRUN] = "adc_ovr",   [SKIN_FAULT_ADC_TIMEOUT] = "adc_to",
    [SKIN_FAULT_LINK_TIMEOUT] = "link_to",  [SKIN_FAULT_HSE_LOST] = "hse_lost",
    [SKIN_FAULT_MUX_STUCK] = "mux",
};

void skin_fault_count(skin_fault_t fault) {
  /* Saturating: a count that wrapped to a small number would hide a fault that persists. */
  if ((unsigned)fault < SKIN_FAULTS && counts[fault] != 0xFFFFFFFFu) {
    counts[fault]++;
  }
}

uint32_t skin_fault_get(skin_fault_t fault) {
  return (unsigned)fault < SKIN_FAULTS ? counts[fault] : 0u;
}

const char *skin_fault_key(skin_fault_t fault) {
  return (unsigned)fault < SKIN_FAULTS ? keys[fault] : "";
}

void skin_faults_clear(void) {
  for (unsigned i = 0; i < SKIN_FAULTS; i++) {
    counts[i] = 0u;
  }
}
