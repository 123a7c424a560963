/*
 * The Nucleo's reset cause and fault record (boards/nucleo_f446re/reset.c), on the host: what
 * the information frame says after each kind of reset.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "reset.h"

static void each_reset_flag_names_its_cause(void **state) {
  (void)state;
  /* As the chip sets them: every reset also pulls NRST (PINRSTF); a power-on sets BORRSTF. */
  const uint32_t pin = NUCLEO_CSR_PINRSTF;
  assert_string_equal(nucleo_reset_cause(pin | NUCLEO_CSR_PORRSTF | NUCLEO_CSR_BORRSTF), "por");
  assert_string_equal(nucleo_reset_cause(pin | NUCLEO_CSR_BORRSTF), "bor");
  assert_string_equal(nucleo_reset_cause(pin), "pin");
  assert_string_equal(nucleo_reset_cause(pin | NUCLEO_CSR_SFTRSTF), "sw");
  assert_string_equal(nucleo_reset_cause(pin | NUCLEO_CSR_IWDGRSTF), "iwdg");
  assert_string_equal(nucleo_reset_cause(pin | NUCLEO_CSR_WWDGRSTF), "wwdg");
  assert_string_equal(nucleo_reset_cause(pin | NUCLEO_CSR_LPWRRSTF), "lpwr");
  /* QEMU's stubbed RCC reads 0. */
  assert_string_equal(nucleo_reset_cause(0u), "unknown");
}

static void a_fault_recorded_before_a_reset_is_read_once(void **state) {
  (void)state;
  nucleo_fault_record_t record = {0};
  nucleo_record_write(&record, NUCLEO_FAULT_BUSFAULT, 0x08001234u);
  uint32_t pc = 0;
  const uint32_t csr = NUCLEO_CSR_PINRSTF | NUCLEO_CSR_SFTRSTF;
  assert_int_equal(nucleo_record_take(&record, csr, &pc), NUCLEO_FAULT_BUSFAULT);
  assert_int_equal(pc, 0x08001234u);
  assert_string_equal(nucleo_fault_name(NUCLEO_FAULT_BUSFAULT), "busfault");
  /* The next reset without a fault finds none. */
  assert_int_equal(nucleo_record_take(&record, csr, &pc), NUCLEO_FAULT_NONE);
  assert_null(nucleo_fault_name(NUCLEO_FAULT_NONE));
}

static void after_power_on_the_record_is_noise(void **state) {
  (void)state;
  nucleo_fault_record_t record = {0};
  nucleo_record_write(&record, NUCLEO_FAULT_HARDFAULT, 0u);
  uint32_t pc = 1;
  assert_int_equal(nucleo_record_take(&record, NUCLEO_CSR_PORRSTF | NUCLEO_CSR_PINRSTF, &pc),
                   NUCLEO_FAULT_NONE);
  assert_int_equal(pc, 0u);
  /* Random RAM that happens to hold the magic still fails the check. */
  nucleo_fault_record_t noise = {0x5346AB1Eu, NUCLEO_FAULT_NMI, 0x1u, 0x12345678u};
  assert_int_equal(nucleo_record_take(&noise, NUCLEO_CSR_SFTRSTF, &pc), NUCLEO_FAULT_NONE);
}

static void every_fault_code_has_a_name(void **state) {
  (void)state;
  for (uint32_t code = NUCLEO_FAULT_NONE + 1; code < NUCLEO_FAULTS; code++) {
    assert_non_null(nucleo_fault_name(code));
  }
  assert_null(nucleo_fault_name(NUCLEO_FAULTS));
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(each_reset_flag_names_its_cause),
      cmocka_unit_test(a_fault_recorded_before_a_reset_is_read_once),
      cmocka_unit_test(after_power_on_the_record_is_noise),
      cmocka_unit_test(every_fault_code_has_a_name),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
