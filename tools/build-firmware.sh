#!/usr/bin/env bash
# Build the firmware: the core and its host tests (run with --test, through ctest), then every
# board image with the ARM toolchain, printing each image's flash and RAM use. Build trees:
# build/fw-host and build/fw-arm.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
test=""
[ "${1:-}" = "--test" ] && test=1
jobs=${SKIN_BUILD_JOBS:-2}
log=$(mktemp)
trap 'rm -f "$log"' EXIT
quiet() { "$@" >"$log" 2>&1 || { cat "$log" >&2; echo "build-firmware: failed: $*" >&2; exit 1; }; }

if [ -n "$test" ]; then
  quiet cmake -S firmware -B build/fw-host
  quiet cmake --build build/fw-host -j "$jobs"
  quiet ctest --test-dir build/fw-host --output-on-failure -j "$jobs"
  echo "build-firmware: host $(grep -E 'tests passed' "$log")"
fi
quiet cmake -S firmware -B build/fw-arm -DCMAKE_TOOLCHAIN_FILE="$PWD/firmware/cmake/arm-none-eabi.cmake" \
  -DCMAKE_BUILD_TYPE=MinSizeRel
quiet cmake --build build/fw-arm -j "$jobs"
for elf in $(find build/fw-arm/boards -name '*.elf' | sort); do
  cmake -DSIZE_TOOL=arm-none-eabi-size -DELF="$elf" -P firmware/cmake/check_size.cmake 2>&1 |
    sed 's/^-- /build-firmware: /'
done
