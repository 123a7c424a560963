#!/usr/bin/env bash
# The kernel's C unit tests (skin_kernel/test, cmocka) built with AddressSanitizer and
# UndefinedBehaviorSanitizer and run through ctest; any sanitizer report fails them. Build tree:
# build/kernel-tests. Without cmocka (tools/setup-firmware.sh installs it as root) prints one
# line saying so and skips them.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
if [ ! -f /usr/include/cmocka.h ]; then
  echo "test-kernel: missing libcmocka-dev; the kernel's C tests are skipped" \
       "(as root: apt-get install libcmocka-dev)" >&2
  exit 0
fi
jobs=${SKIN_BUILD_JOBS:-2}
log=$(mktemp)
trap 'rm -f "$log"' EXIT
quiet() { "$@" >"$log" 2>&1 || { cat "$log" >&2; echo "test-kernel: failed: $*" >&2; exit 1; }; }
quiet cmake -S skin_kernel/test -B build/kernel-tests
quiet cmake --build build/kernel-tests -j "$jobs"
quiet ctest --test-dir build/kernel-tests --output-on-failure -j "$jobs"
echo "test-kernel: $(grep -E 'tests passed' "$log") (AddressSanitizer, UBSan)"
