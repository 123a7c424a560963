#!/usr/bin/env bash
# Make sure the firmware can be built, tested and emulated: the ARM toolchain with newlib,
# cmocka for the host tests and QEMU for the emulated board (Debian/Ubuntu packages). As root,
# installs what is missing; otherwise prints one line naming it and exits 1, so that callers
# (tools/run-tests.sh) skip the firmware steps. Exits 2 when an installation fails.
set -euo pipefail

missing() {
  local pkgs=()
  command -v arm-none-eabi-gcc >/dev/null 2>&1 || pkgs+=(gcc-arm-none-eabi)
  if ! command -v arm-none-eabi-gcc >/dev/null 2>&1 \
     || [ ! -f "$(arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 \
                   -print-file-name=libc_nano.a)" ]; then
    pkgs+=(libnewlib-arm-none-eabi)
  fi
  command -v qemu-system-arm >/dev/null 2>&1 || pkgs+=(qemu-system-arm)
  [ -f /usr/include/cmocka.h ] || pkgs+=(libcmocka-dev)
  command -v cmake >/dev/null 2>&1 || pkgs+=(cmake)
  command -v cc >/dev/null 2>&1 || pkgs+=(gcc)
  echo "${pkgs[@]}"
}

want=$(missing)
[ -z "$want" ] && exit 0
if [ "$(id -u)" -ne 0 ] || ! command -v apt-get >/dev/null 2>&1; then
  echo "setup-firmware: missing $want; the firmware is not built or tested without them" \
       "(as root: apt-get install $want)" >&2
  exit 1
fi
echo "setup-firmware: installing $want" >&2
log=$(mktemp)
if ! { DEBIAN_FRONTEND=noninteractive apt-get update -q \
       && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $want; } \
       >"$log" 2>&1; then
  tail -n 5 "$log" >&2
  echo "setup-firmware: apt-get could not install $want (log: $log)" >&2
  exit 2
fi
rm -f "$log"
left=$(missing)
if [ -n "$left" ]; then
  echo "setup-firmware: still missing after apt-get: $left" >&2
  exit 2
fi
