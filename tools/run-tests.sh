#!/usr/bin/env bash
# Run the whole test suite inside the workspace environment; extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
# A domain of its own keeps this run's nodes apart from anything else on the machine; each
# pytest-xdist worker takes the next one (test/conftest.py).
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(( (RANDOM % 80) + 10 ))}"
export PYTHONDONTWRITEBYTECODE=1
# The firmware first: its set-up (as root it installs the ARM toolchain, cmocka and QEMU), the
# core's host tests and every board's image. Without them and not root, setup-firmware.sh says
# in one line what is missing and the firmware steps are skipped (test/firmware skips too).
set +e
bash tools/setup-firmware.sh
fw=$?
set -e
case $fw in
  0) bash tools/build-firmware.sh --test ;;
  1) ;;
  *) exit "$fw" ;;
esac
# The kernel's C unit tests under the sanitizers (cmocka, which the firmware's set-up installs).
bash tools/test-kernel.sh
# Every test is bounded by pytest itself (pytest.ini: pytest-timeout, and the faulthandler for a
# hang in native code, which ends the worker with every thread's stack); SKIN_TEST_WALL_S (0 for
# none) stops the run between two tests once past it.
set +e
wall="${SKIN_TEST_WALL_S:-1800}"
bound=()
if [ "$wall" != 0 ]; then
  bound=(--session-timeout "$wall")  # pytest-timeout reads 0 as "already past"
fi
tools/with-env.sh python -m pytest -n "${SKIN_TEST_WORKERS:-2}" "${bound[@]}" "$@"
rc=$?
set -e
if [ "$rc" -eq 5 ]; then
  echo "run-tests: pytest collected no test; that is a failure here" >&2
  exit 1
fi
exit "$rc"
